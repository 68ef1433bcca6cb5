// The cost model: fitted on records made from known linear costs, it gives those costs
// back; hangs are priced per template and material with fallbacks; the schedule waits
// for garments and fits made once; build.json records read back; the ETA.
#include "generator/pipeline/cost.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "common/error.h"
#include "common/files.h"
#include "common/testing.h"
#include "generator/hang/hang.h"
#include "generator/recipe/recipe.h"

namespace fs = std::filesystem;
namespace drape {
namespace {

JobDrivers Drivers(const std::string& tmpl, int nodes, int frames, double vpm, int instance) {
  JobDrivers d;
  d.template_name = tmpl;
  d.material = "cotton";
  d.fit_key = "cotton";
  d.instance = tmpl + "/i" + std::to_string(instance);
  d.nodes = nodes;
  d.faces = 2 * nodes;
  d.area = nodes * 1e-3;
  d.frames = frames;
  d.fused_frames = (frames + 2) / 3;
  d.voxels_per_metre = vpm;
  d.hang_ply_bytes = 200 + 25 * nodes;
  return d;
}

// Costs of a made-up machine: what each stage's model must find again.
EntryCost Measured(const JobDrivers& d, double hang_per_node) {
  EntryCost e;
  e.job = d;
  const double S = d.Surface();
  e.cpu = {{"hang", hang_per_node * d.nodes},
           {"sweep", 0.004 * d.frames + 2e-6 * d.frames * d.nodes},
           {"fusion", 0.003 * d.fused_frames + 4e-8 * d.fused_frames * S},
           {"accuracy", 2e-6 * S + 1e-4 * d.nodes},
           {"feature", 1e-7 * S},
           {"encode", 3e-7 * S + 1e-5 * d.nodes},
           {"preview", 0.05 + 1e-7 * S + 1e-5 * d.nodes},
           {"garment", 1e-4 * d.nodes},
           {"fit", 1.5}};
  e.bytes = {{"hang.ply", double(d.hang_ply_bytes)},
             {"recon.ply", 0.5 * S},
             {"sdf.vdb", 0.25 * S},
             {"feature.bin", 536},
             {"preview.png", 1e5}};
  return e;
}

BuildCost MadeUpBuild() {
  BuildCost b;
  b.release = "made-up 1.0.0";
  b.source = "made-up";
  int k = 0;
  for (int nodes : {300, 350, 400, 600, 800})
    for (int frames : {36, 120})
      for (double vpm : {128.0, 256.0}) {
        b.entries.push_back(Measured(Drivers("towel", nodes, frames, vpm, k++ % 3), 0.02));
        b.entries.push_back(Measured(Drivers("shorts", nodes, frames, vpm, k++ % 3), 0.05));
      }
  for (const EntryCost& e : b.entries)
    for (const auto& [f, n] : e.bytes) b.entry_bytes += n;
  b.commit_cpu = 1e-8 * b.entry_bytes;
  b.viewer_mesh_bytes = 1e6;
  b.fixed_bytes = 7e5;
  b.per_entry_bytes = 1.2e4;
  b.entries_in_release = static_cast<int>(b.entries.size());
  b.finalize_cpu = 2.0;
  return b;
}

TEST(CostModel, FitsKnownLinearCostsBack) {
  const CostModel m = CostModel::Fit({MadeUpBuild()});
  ASSERT_FALSE(m.empty());
  for (const JobDrivers& d : {Drivers("towel", 500, 300, 384, 9), Drivers("shorts", 1000, 60, 128, 9)}) {
    const EntryCost want = Measured(d, d.template_name == "towel" ? 0.02 : 0.05);
    const auto cpu = m.JobCpu(d);
    for (const char* stage : {"hang", "sweep", "fusion", "accuracy", "feature", "encode", "preview"})
      EXPECT_NEAR(cpu.at(stage), want.cpu.at(stage), 1e-6 * (1 + want.cpu.at(stage))) << stage;
    const auto bytes = m.JobBytes(d);
    for (const char* file : {"hang.ply", "recon.ply", "sdf.vdb", "feature.bin", "preview.png"})
      EXPECT_NEAR(bytes.at(file), want.bytes.at(file), 1e-3 * want.bytes.at(file)) << file;
    EXPECT_NEAR(m.GarmentCpu(d), 1e-4 * d.nodes, 1e-9);
    EXPECT_NEAR(m.FitCpu(d), 1.5, 1e-9);
  }
}

// A noise-free sweep costs less and fuses smaller: where records say which sweeps were
// noisy, the sweep, the fusion, recon.ply, sdf.vdb and the preview are priced per kind; a record that
// does not say (made before the key) counts only in the pooled fit, which a job of an
// unrecorded kind falls back to.
TEST(CostModel, SweepNoiseIsADriverWhereRecordsSayIt) {
  BuildCost b = MadeUpBuild();
  for (size_t i = 0; i < b.entries.size(); ++i) {
    EntryCost& e = b.entries[i];
    e.job.noise = static_cast<int>(i % 2);
    const double k = e.job.noise ? 1.0 : 0.6, S = e.job.Surface();
    e.bytes["recon.ply"] = 0.5 * k * S, e.bytes["sdf.vdb"] = 0.25 * k * S, e.bytes["preview.png"] = 1e5 * k;
    e.cpu["sweep"] *= k, e.cpu["fusion"] *= k;
  }
  const CostModel m = CostModel::Fit({b});
  for (int noise : {0, 1}) {
    JobDrivers d = Drivers("towel", 500, 120, 256, 9);
    const EntryCost plain = Measured(d, 0.02);
    d.noise = noise;
    const double k = noise ? 1.0 : 0.6;
    const auto bytes = m.JobBytes(d);
    const auto cpu = m.JobCpu(d);
    EXPECT_NEAR(bytes.at("recon.ply"), k * plain.bytes.at("recon.ply"), 1e-3 * plain.bytes.at("recon.ply"));
    EXPECT_NEAR(bytes.at("sdf.vdb"), k * plain.bytes.at("sdf.vdb"), 1e-3 * plain.bytes.at("sdf.vdb"));
    EXPECT_NEAR(bytes.at("preview.png"), k * 1e5, 1e-6);  // a file priced at its mean
    EXPECT_NEAR(cpu.at("sweep"), k * plain.cpu.at("sweep"), 1e-6 * (1 + plain.cpu.at("sweep")));
    EXPECT_NEAR(cpu.at("fusion"), k * plain.cpu.at("fusion"), 1e-6 * (1 + plain.cpu.at("fusion")));
    EXPECT_NEAR(cpu.at("accuracy"), plain.cpu.at("accuracy"), 1e-6 * (1 + plain.cpu.at("accuracy")));  // not driven
  }
  // Records before the key: one pooled model, whatever the job's noise.
  for (EntryCost& e : b.entries) e.job.noise = -1;
  const CostModel pooled = CostModel::Fit({b});
  JobDrivers d = Drivers("towel", 500, 120, 256, 9);
  d.noise = 0;
  const double clean = pooled.JobBytes(d).at("recon.ply");
  d.noise = 1;
  EXPECT_EQ(pooled.JobBytes(d).at("recon.ply"), clean);
  // The key reads back, and its absence reads as not recorded.
  d.noise = 0;
  EXPECT_EQ(DriversFromJson(DriversJson(d)).noise, 0);
  Json old = DriversJson(d);
  old.erase("noise");
  EXPECT_EQ(DriversFromJson(old).noise, -1);
}

TEST(CostModel, HangFallsBackToTemplateThenAll) {
  BuildCost b = MadeUpBuild();
  double shorts_cpu = 0, shorts_nodes = 0;
  for (const EntryCost& e : b.entries)
    if (e.job.template_name == "shorts") shorts_cpu += e.cpu.at("hang"), shorts_nodes += e.job.nodes;
  // Only two hangs of shorts in jeans: too few for their own price, so the shorts' one.
  for (int i = 0; i < 2; ++i) {
    b.entries.push_back(Measured(Drivers("shorts", 500, 36, 128, 0), 1.0));
    b.entries.back().job.material = "jeans";
  }
  JobDrivers jeans = Drivers("shorts", 1000, 36, 128, 0);
  jeans.material = "jeans";
  bool fallback = true;
  EXPECT_NEAR(CostModel::Fit({b}).JobCpu(jeans, &fallback).at("hang"),
              1000 * (shorts_cpu + 1000) / (shorts_nodes + 1000), 1e-9);
  EXPECT_FALSE(fallback);
  // A third: jeans shorts get their own price.
  b.entries.push_back(b.entries.back());
  const CostModel m = CostModel::Fit({b});
  EXPECT_NEAR(m.JobCpu(jeans).at("hang"), 1000, 1e-9);
  // A template never measured: the mean per node over every hang.
  double cpu = 0, nodes = 0;
  for (const EntryCost& e : b.entries) cpu += e.cpu.at("hang"), nodes += e.job.nodes;
  EXPECT_NEAR(m.JobCpu(Drivers("pants", 1000, 36, 128, 0), &fallback).at("hang"), 1000 * cpu / nodes, 1e-9);
  EXPECT_TRUE(fallback);
}

TEST(CostModel, RecordsAreScaledToThisMachineBySpeedProbe) {
  // Built on a machine whose probe took 0.05 s; priced for one that takes 0.1 s: every
  // CPU figure doubles, bytes stay.
  BuildCost b = MadeUpBuild();
  b.probe_cpu = 0.05;
  const JobDrivers d = Drivers("shorts", 1000, 120, 256, 9);
  const CostModel as_measured = CostModel::Fit({b});
  const CostModel scaled = CostModel::Fit({b}, 0.1);
  EXPECT_FALSE(as_measured.scaled());
  EXPECT_TRUE(scaled.scaled());
  for (const auto& [stage, cpu] : as_measured.JobCpu(d))
    EXPECT_NEAR(scaled.JobCpu(d).at(stage), 2 * cpu, 1e-9 * (1 + cpu)) << stage;
  EXPECT_NEAR(scaled.FitCpu(d), 3.0, 1e-9);
  EXPECT_NEAR(scaled.FinalizeCpu(1e8), 2 * as_measured.FinalizeCpu(1e8), 1e-9);
  EXPECT_EQ(scaled.JobBytes(d), as_measured.JobBytes(d));
  // A build without a probe is left out beside one with it (its machine is unknown)...
  BuildCost other = MadeUpBuild();
  for (EntryCost& e : other.entries) e.cpu["hang"] *= 10;
  const CostModel mixed = CostModel::Fit({b, other}, 0.1);
  EXPECT_NEAR(mixed.JobCpu(d).at("hang"), scaled.JobCpu(d).at("hang"), 1e-9);
  EXPECT_EQ(mixed.records(), static_cast<int>(b.entries.size()));
  // ... and taken as measured when no build has one.
  const CostModel unprobed = CostModel::Fit({other}, 0.1);
  EXPECT_FALSE(unprobed.scaled());
  EXPECT_NEAR(unprobed.JobCpu(d).at("hang"), 10 * as_measured.JobCpu(d).at("hang"), 1e-6);
}

TEST(CostModel, SpeedProbeMeasuresTheSimulation) {
  const double probe = SpeedProbeCpuSeconds();
  EXPECT_TRUE(std::isfinite(probe));
  EXPECT_GT(probe, 0.0);  // 240 steps of a 176-node cloth are never free
}

TEST(CostModel, NoRecordsGiveAnEmptyModel) {
  const CostModel m = CostModel::Fit({});
  EXPECT_TRUE(m.empty());
  EXPECT_TRUE(m.JobCpu(Drivers("towel", 300, 36, 128, 0)).empty());
}

TEST(CostModel, BuildJsonRecordsReadBack) {
  const fs::path dir = FreshTempDir("drape_cost_read");
  const JobDrivers d = Drivers("towel", 341, 36, 128, 0);
  Json timing{{"hang", 9.5},
              {"cpu", {{"hang", 1.25}, {"sweep", 0.5}}},
              {"job", DriversJson(d)},
              {"bytes", {{"hang.ply", 13154}, {"sweep", 4096}}}};
  Json old_entry{{"hang", 3.0}};  // a build from before cost records: skipped
  Json build{
      {"finished", "2026-12-05T10:00:00Z"},
      {"host", "h"},
      {"entry_timing", {{"00000-a", timing}, {"00001-b", old_entry}}},
      {"costs", {{"release", "tiny 0.1.0"}, {"commit_cpu_seconds", 0.5}, {"probe_cpu_seconds", 0.04}, {"entries", 2}}}};
  WriteFileAtomic(dir / "build.json", build.dump());
  const BuildCost c = ReadBuildCost(dir / "build.json");
  EXPECT_EQ(c.release, "tiny 0.1.0");
  ASSERT_EQ(c.entries.size(), 1u);
  EXPECT_EQ(c.entries[0].job.nodes, 341);
  EXPECT_EQ(c.entries[0].job.instance, d.instance);
  EXPECT_EQ(c.entries[0].cpu.at("hang"), 1.25);
  EXPECT_EQ(c.entry_bytes, 13154 + 4096);
  EXPECT_EQ(c.commit_cpu, 0.5);
  EXPECT_EQ(c.finalize_cpu, -1);  // absent
  EXPECT_EQ(c.probe_cpu, 0.04);
  // Found through datasets/*/*/: of two records of one release, the later one.
  fs::create_directories(dir / "datasets/tiny/0.1.0");
  fs::create_directories(dir / "datasets/tiny/0.1.1");
  WriteFileAtomic(dir / "datasets/tiny/0.1.0/costs.json", build.dump());
  build["finished"] = "2026-12-06T10:00:00Z";
  WriteFileAtomic(dir / "datasets/tiny/0.1.1/build.json", build.dump());
  WriteFileAtomic(dir / "datasets/tiny/0.1.1/costs.json", "{not json");
  std::vector<std::string> notes;
  const auto found = FindBuildCosts(dir, {}, &notes);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].finished, "2026-12-06T10:00:00Z");
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_CONTAINS(notes[0], "costs.json: not JSON");
  // A damaged job record names the file and the entry.
  build["entry_timing"]["00000-a"]["job"].erase("nodes");
  WriteFileAtomic(dir / "bad.json", build.dump());
  EXPECT_CONTAINS(ErrorOf([&] { ReadBuildCost(dir / "bad.json"); }), "bad.json: entry_timing 00000-a");
}

// A small recipe for plans: 12-frame sweeps at 96 voxels/m, then `garments_and_splits`.
Recipe PlanRecipe(const std::string& garments_and_splits) {
  return ParseRecipe(R"(name: plan
version: 0.0.1
seed: 3
sensing:
  database: {frames: 12}
  sensed: {frames: 12}
fusion: {voxels_per_metre: 96}
)" + garments_and_splits,
                     "plan.yaml", fs::current_path());
}

// Every job of the expansion, in order.
std::vector<int> AllJobs(const std::vector<Job>& jobs) {
  std::vector<int> all(jobs.size());
  for (size_t i = 0; i < jobs.size(); ++i) all[i] = static_cast<int>(i);
  return all;
}

// A recipe of two garments: the plan counts jobs per split and garment, makes each
// instance's garment once and schedules the pool: on one thread the wall is the CPU.
TEST(CostModel, PlanCountsJobsAndSchedulesThePool) {
  const Recipe r = PlanRecipe(R"(garments:
  - {template: towel, size: S, edge_length: 0.08, instances: 2, materials: [towel_b]}
  - {template: shorts, edge_length: 0.08, instances: 2, materials: [pants]}
splits:
  train:
    garments: [{garment: towel, instances: [0]}, {garment: shorts, instances: [0]}]
  test:
    garments: [{garment: towel, instances: [1], max_anchors: 2}, {garment: shorts, instances: [1], max_anchors: 2}]
)");
  const std::vector<Job> jobs = ExpandJobs(r);
  const std::vector<int> all = AllJobs(jobs);
  const CostModel m = CostModel::Fit({MadeUpBuild()});
  const BuildPlan one = PlanBuild(r, jobs, all, 1, m), two = PlanBuild(r, jobs, all, 2, m);
  EXPECT_EQ(one.jobs, static_cast<int>(jobs.size()));
  EXPECT_EQ(one.jobs_per_split.at("test").at("towel"), 2);
  EXPECT_EQ(one.jobs_per_split.at("test").at("shorts"), 2);
  int train = 0;
  for (const auto& [g, n] : one.jobs_per_split.at("train")) train += n;
  EXPECT_EQ(train + 4, one.jobs);
  EXPECT_NEAR(one.wall_seconds, one.cpu_seconds, 1e-9 * one.cpu_seconds);
  EXPECT_NEAR(two.cpu_seconds, one.cpu_seconds, 1e-9 * one.cpu_seconds);
  EXPECT_LT(two.wall_seconds, 0.75 * one.wall_seconds);
  EXPECT_GT(two.wall_seconds, 0.5 * one.wall_seconds);
  // Garments once per instance (4), the fit once per material (2).
  EXPECT_NEAR(one.stage_cpu.at("fit"), 2 * 1.5, 1e-9);
  EXPECT_GT(one.bytes, one.file_bytes.at("recon.ply"));
  const Json j = PlanJson(two, m);
  for (const char* k : {"jobs", "wall_s", "cpu_s", "bytes"}) EXPECT_TRUE(j.contains(k)) << k;
}

// A material jittered per hang is a material of its own: the build fits it again
// (FitKey), so the plan prices one fit per draw, not one per material name.
TEST(CostModel, PlanPricesAFitPerJitteredMaterial) {
  const Recipe r = PlanRecipe(R"(garments:
  - {template: towel, size: S, edge_length: 0.08, instances: 2, materials: [towel_b]}
splits:
  train:
    garments: [{garment: towel, instances: [0], max_anchors: 2}]
    hangs_per_anchor: 3
    hang_variation: {material_jitter: 0.1}
)");
  const std::vector<Job> jobs = ExpandJobs(r);
  const std::vector<int> all = AllJobs(jobs);
  std::set<std::string> keys;
  for (const Job& job : jobs) keys.insert(FitKey(job.material, HangOptionsFor(r, r.garments[job.garment])));
  ASSERT_EQ(keys.size(), 5u);  // hang 0's material (both anchors) and each other hang's draw
  const BuildPlan plan = PlanBuild(r, jobs, all, 1, CostModel::Fit({MadeUpBuild()}));
  EXPECT_NEAR(plan.stage_cpu.at("fit"), 5 * 1.5, 1e-9);
}

TEST(EtaClock, ModelledJobsScaleByTheFinishedOnes) {
  EtaClock eta({1, 2, 3, 4}, 2);
  EXPECT_DOUBLE_EQ(eta.Remaining(), 10.0 / 2);  // before any job: the model on idle cores
  eta.Done(1, 6);                               // the machine runs 3x slower than priced
  EXPECT_DOUBLE_EQ(eta.Remaining(), 8.0 * 3 / 2);
  eta.Done(1, 100);  // twice: ignored
  EXPECT_DOUBLE_EQ(eta.Remaining(), 8.0 * 3 / 2);
  EtaClock plain({0, 0, 0}, 1);  // no model: the mean job time once one finished
  EXPECT_TRUE(std::isnan(plain.Remaining()));
  plain.Done(0, 4);
  EXPECT_DOUBLE_EQ(plain.Remaining(), 8);
}

}  // namespace
}  // namespace drape
