#include "generator/pipeline/build.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <future>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "common/cpu_time.h"
#include "common/error.h"
#include "common/files.h"
#include "common/parallel.h"
#include "common/rng.h"
#include "common/timing.h"
#include "common/version.h"
#include "garments/io.h"
#include "garments/templates.h"
#include "generator/feature/feature.h"
#include "generator/fusion/fusion.h"
#include "generator/hang/hang.h"
#include "generator/pipeline/cost.h"
#include "generator/release/release.h"
#include "generator/sweep/sweep.h"

namespace fs = std::filesystem;

namespace drape {

namespace {

// A value computed once per key by whichever job needs it first; other jobs wait.
template <typename T>
class OnceMap {
 public:
  template <typename Fn>
  std::shared_ptr<const T> Get(const std::string& key, Fn&& make, bool* computed_here = nullptr) {
    std::shared_future<std::shared_ptr<const T>> fut;
    std::promise<std::shared_ptr<const T>> promise;
    bool mine = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      auto it = map_.find(key);
      if (it == map_.end()) {
        fut = promise.get_future().share();
        map_.emplace(key, fut);
        mine = true;
      } else {
        fut = it->second;
      }
    }
    if (computed_here) *computed_here = mine;
    if (mine) {
      try {
        promise.set_value(std::make_shared<const T>(make()));
      } catch (...) {
        promise.set_exception(std::current_exception());
      }
    }
    return fut.get();
  }

 private:
  std::mutex mu_;
  std::map<std::string, std::shared_future<std::shared_ptr<const T>>> map_;
};

Json MaterialJson(const Material& m) {
  Json j = {{"stretch_percent", m.stretch_percent},
            {"friction_deg", m.friction_deg},
            {"area_density", m.area_density},
            {"bending_stiffness", m.bending_stiffness}};
  if (m.bending_rigidity > 0) {  // hinge bending (absent otherwise: older records keep their bytes)
    j["bending_rigidity"] = m.bending_rigidity;
    j["crease_yield"] = m.crease_yield;
    j["crease_weakening"] = m.crease_weakening;
    if (m.crease_recovery_deg > 0) j["crease_recovery"] = m.crease_recovery_deg;  // (absent: older records)
  }
  return j;
}

Json HangStatsJson(const HangStats& s) {
  return {{"sim_time", s.sim_time},
          {"steps", s.steps},
          {"time_step", s.time_step},
          {"kinetic_energy", s.kinetic_energy},
          {"max_speed", s.max_speed},
          {"settled", s.settled},
          {"settle_motion", s.settle_motion},
          {"held_nodes", s.held_nodes},
          {"held_layers", s.held_layers},
          {"intersecting_pairs", s.intersecting_pairs},
          {"min_distance", s.min_distance},
          {"strain_mean", s.strain_mean},
          {"strain_median", s.strain_median},
          {"strain_p99", s.strain_p99},
          {"strain_max", s.strain_max},
          {"strain_limit", s.strain_limit},
          {"com_offset", s.com_offset},
          {"ccd_collisions", s.ccd_collisions},
          {"fail_safe_steps", s.fail_safe_steps},
          {"remaining_collisions", s.remaining_collisions},
          {"strain_violation_steps", s.strain_violation_steps},
          {"retries", s.retries}};
}

}  // namespace

struct JobCache::Impl {
  OnceMap<Garment> garments;
  OnceMap<MaterialFit> fits;
};
JobCache::JobCache() : impl(std::make_unique<Impl>()) {}
JobCache::~JobCache() = default;

fs::path DefaultOutput(const Recipe& recipe) { return fs::path("datasets") / recipe.name / recipe.version; }

namespace {

// The garment of a job's instance, made (or imported) and size-scaled once per
// instance: every anchor of it shares it.
std::shared_ptr<const Garment> InstanceGarment(const Recipe& recipe, const Job& job, JobCache& cache) {
  const std::string gkey = job.instance_name + "@" + std::to_string(job.size_scale);
  return cache.impl->garments.Get(gkey, [&] { return MakeJobGarment(recipe, job); });
}

// The material's stiffness, fitted once per material values and fit resolution.
std::shared_ptr<const MaterialFit> MaterialFitFor(const Material& m, const HangOptions& hang_options, JobCache& cache) {
  return cache.impl->fits.Get(FitKey(m, hang_options), [&] { return FitMaterial(m, hang_options); });
}

// What a record says about the job itself: garment, instance, material, anchor, seed.
void RecordJob(Json& rec, const Job& job, const GarmentSpec& g, const Garment& garment, const MaterialFit& fit,
               const Anchor& anchor, const Vec3& offset) {
  rec["category"] = garment.category;
  rec["garment"] = g.name;
  rec["template"] = g.template_name.empty() ? g.file.filename().string() : g.template_name;
  rec["instance"] = job.instance_name;
  rec["instance_name"] = garment.instance;
  if (!g.template_name.empty()) rec["size"] = g.options.size;
  rec["size_scale"] = job.size_scale;
  rec["material"] = job.material_name;
  rec["material_values"] = MaterialJson(job.material);
  rec["material_fit"] = {{"stiffness", fit.stiffness},
                         {"target_stretch_percent", fit.target_stretch_percent},
                         {"reproduced_stretch_percent", fit.reproduced_stretch_percent},
                         {"converged", fit.converged},
                         {"friction", fit.friction},
                         {"target_friction_deg", fit.target_friction_deg},
                         {"reproduced_friction_deg", fit.reproduced_friction_deg}};
  if (job.material.bending_rigidity > 0) {  // the hinge constant and the cantilever it reproduces
    rec["material_fit"]["bending_scale"] = fit.bending_scale;
    rec["material_fit"]["target_bending_length"] = fit.target_bending_length;
    rec["material_fit"]["reproduced_bending_length"] = fit.reproduced_bending_length;
  }
  if (job.material.crease_recovery_deg > 0) {  // the yield fitted to the measured crease recovery
    rec["material_fit"]["crease_yield"] = fit.crease_yield;
    rec["material_fit"]["reproduced_crease_recovery"] = fit.reproduced_crease_recovery_deg;
  }
  rec["anchor"] = {{"label", anchor.label}, {"vertex", anchor.vertex}, {"uv", PointJson(anchor.uv)}};
  rec["grasp_offset"] = {offset.x(), offset.y(), offset.z()};
  rec["seed"] = job.seed;
  if (job.turn != 0) rec["turn_radians"] = job.turn;
  if (job.pose_noise_degrees > 0) rec["gripper_pose_noise_degrees"] = job.pose_noise_degrees;
  if (job.repeat) rec["repeat"] = job.repeat;
  if (job.hang > 0) {  // hang k ≥ 1 of hangs_per_anchor (absent for hang 0: K = 1 keeps its bytes)
    rec["hang_index"] = job.hang;
    const double* mj = job.hang_material_jitter;
    rec["hang_variation"] = {{"grasp_miss", {job.hang_miss.x(), job.hang_miss.y()}},
                             {"material_jitter", {mj[0], mj[1], mj[2], mj[3]}},
                             {"pickup_spin", {job.pickup_spin.x(), job.pickup_spin.y(), job.pickup_spin.z()}}};
  }
  rec["garment_mesh"] = {{"vertices", garment.mesh.NumVertices()}, {"faces", garment.mesh.NumFaces()}};
}

Json SweepRecord(const Sweep& sweep, const SweepOptions& o) {
  return {{"frames", sweep.stats.frames},
          {"degrees", o.degrees},
          {"back_and_forth", o.back_and_forth},
          {"noise", o.kinect.noise},
          {"garment_pixels_mean", sweep.stats.garment_pixels_mean},
          {"valid_fraction_mean", sweep.stats.valid_fraction_mean},
          {"warnings", sweep.stats.warnings}};
}

Json FusionRecord(const Accuracy& acc, const FusionResult& fused, const FusionOptions& o) {
  return {{"recon_to_truth_mean", acc.recon_to_truth_mean},
          {"recon_to_truth_p95", acc.recon_to_truth_p95},
          {"truth_to_recon_mean", acc.truth_to_recon_mean},
          {"truth_to_recon_p95", acc.truth_to_recon_p95},
          {"voxels_per_metre", o.voxels_per_metre},
          {"truncation", o.Truncation()},
          {"frames_integrated", fused.stats.frames_integrated},
          {"surface_blocks", fused.stats.surface_blocks},
          {"mesh_vertices", fused.mesh.NumVertices()},
          {"mesh_faces", fused.mesh.NumFaces()}};
}

// preview.png: hung mesh with its grasp point, the depth frame a quarter turn in
// (the garment from the side) and the reconstruction.
std::string EntryPreview(const Job& job, const HangResult& hung, const Anchor& anchor, const Sweep& sweep,
                         const FusionResult& fused) {
  std::string depth_png;
  if (!sweep.frames.empty()) depth_png = RenderDepthPreview(sweep.frames[sweep.frames.size() / 4], sweep.intrinsics);
  const Vec3 anchor_hung = anchor.vertex >= 0 && anchor.vertex < hung.mesh.NumVertices()
                               ? Vec3(hung.mesh.V.row(anchor.vertex).transpose())
                               : Vec3::Zero();
  return RenderEntryPreview(hung.mesh, anchor_hung, depth_png, fused.mesh, job.key + " (" + job.split + ")");
}

// The hang's thread CPU time and every part of it, as "hang.<part>" keys of the timing
// record (LogStageSeconds prints them as the hang's own line), and why a retried hang's
// first attempt failed ("hang_retry_reason").
void HangCostTiming(const HangStats& s, Json& timing) {
  for (const HangCostPart& p : kHangCostParts) timing[std::string("hang.") + p.name] = s.*p.seconds;
  if (!s.retry_reason.empty()) timing["hang_retry_reason"] = s.retry_reason;
}

// Times each stage of an entry into its timing record: wall seconds by stage name, and
// the job thread's CPU seconds in `cpu` (what the cost model reads; every stage of a job
// runs on its thread).
struct StageClock {
  Json& timing;
  Json cpu = Json::object();
  template <class Fn>
  void operator()(const char* name, Fn&& fn) {
    const auto t0 = Clock::now();
    const double c0 = ThreadCpuSeconds();
    fn();
    timing[name] = Since(t0);
    cpu[name] = ThreadCpuSeconds() - c0;
  }
};

// The stages after the hang: sweep the hung mesh (turned by job.turn), fuse, measure,
// extract the feature, encode the files and the preview into e. Returns why the entry
// failed, or "" when it did not.
std::string SenseHung(const Recipe& recipe, const SensingSpec& sensing, const Job& job, const Anchor& anchor,
                      HangResult& hung, StageClock& stage, Entry& e) {
  Json& rec = e.record;
  Sweep sweep;
  stage("sweep", [&] {
    if (job.turn != 0) {
      // Turned about the gripper: row vectors, so V·Rᵀ.
      hung.mesh.V = hung.mesh.V * Eigen::AngleAxisd(job.turn, Vec3::UnitY()).toRotationMatrix().transpose();
    }
    SweepOptions so = sensing.sweep;
    so.threads = 1;  // jobs run in parallel; one thread each
    sweep = SimulateSweep(hung.mesh, so, DeriveSeed(job.seed, "sweep"));
  });
  rec["sweep"] = SweepRecord(sweep, sensing.sweep);

  FusionResult fused;
  stage("fusion", [&] {
    FusionOptions fo = recipe.fusion;
    fo.threads = 1;
    if (job.pose_noise_degrees > 0) fo.pose_noise_degrees = job.pose_noise_degrees;
    fused = FuseFrames(sweep.frames, sweep.intrinsics, fo, DeriveSeed(job.seed, "fusion"));
  });
  if (fused.mesh.NumFaces() == 0) return "fusion: the fused surface is empty (garment not in view?)";
  Accuracy acc;
  stage("accuracy", [&] { acc = MeasureAccuracy(fused.mesh, hung.mesh); });
  rec["fusion"] = FusionRecord(acc, fused, recipe.fusion);

  Feature feature;
  stage("feature", [&] {
    const Tsdf& tsdf = *fused.tsdf;
    feature = ExtractFeature(
        fused.mesh.V, [&tsdf](const Vec3& p) { return tsdf.Sdf(p); }, recipe.feature);
  });
  rec["feature"] = {
      {"layers", feature.layers}, {"rings", feature.rings}, {"sectors", feature.sectors}, {"ones", feature.PopCount()}};
  // Recorded only when not Algorithm 1's, so releases built before the option keep their digest.
  if (recipe.feature.origin != FeatureOptions().origin) rec["feature"]["origin"] = recipe.feature.origin;

  stage("encode", [&] {
    e.files.push_back({"hang.ply", EncodeMesh(hung.mesh)});
    e.files.push_back({"recon.ply", EncodeMesh(fused.mesh)});
    e.files.push_back({"sdf.vdb", fused.tsdf->EncodeVdb()});
    e.files.push_back({"feature.bin", EncodeFeature(feature)});
    if (sensing.keep_frames)
      for (auto& [path, bytes] : EncodeSweep(sweep)) e.files.push_back({path, std::move(bytes)});
  });
  stage("preview", [&] { e.files.push_back({"preview.png", EntryPreview(job, hung, anchor, sweep, fused)}); });
  return "";
}

}  // namespace

Entry BuildEntry(const Recipe& recipe, const Job& job, JobCache& cache) {
  const auto t_start = Clock::now();
  const GarmentSpec& g = recipe.garments.at(job.garment);
  const SensingSpec& sensing = recipe.sensing.at(job.sensing);
  Entry e;
  e.id = job.id;
  e.key = job.key;
  e.split = job.split;
  Json timing = Json::object();
  StageClock stage{timing};

  std::shared_ptr<const Garment> garment;
  stage("garment", [&] { garment = InstanceGarment(recipe, job, cache); });
  const HangOptions hang_options = HangOptionsFor(recipe, g);
  std::shared_ptr<const MaterialFit> fit;
  stage("fit", [&] { fit = MaterialFitFor(job.material, hang_options, cache); });

  const Anchor* anchor = garment->FindAnchor(job.anchor);
  if (!anchor) throw Error(job.key + ": garment '" + g.name + "' has no anchor '" + job.anchor + "'");
  const Vec3 offset(job.grasp_offset.x(), job.grasp_offset.y(), 0.0);
  Json& rec = e.record;
  RecordJob(rec, job, g, *garment, *fit, *anchor, offset);

  // The timing record ends with what the cost model reads (generator/pipeline/cost.h):
  // the stages' CPU, what drove them and the files' bytes.
  auto finish_timing = [&] {
    timing["total"] = Since(t_start);
    timing["cpu"] = stage.cpu;
    timing["job"] = DriversJson(DriversFor(recipe, job, *garment));
    Json bytes = Json::object();
    for (const auto& f : e.files) {
      const std::string kind = f.path.rfind("sweep/", 0) == 0 ? "sweep" : f.path;
      bytes[kind] = bytes.value(kind, 0.0) + static_cast<double>(f.bytes.size());
    }
    timing["bytes"] = bytes;
    if (e.failed) timing["failed"] = true;
    e.timing = timing;
  };
  auto fail = [&](const std::string& why) {
    e.failed = true;
    e.failure = why;
    finish_timing();
    return e;
  };

  try {
    HangResult hung;
    stage("hang", [&] {
      hung = Hang(*garment, anchor->vertex, offset, job.material, *fit, hang_options, job.hang_seed,
                  HangStart{job.pickup_spin});
    });
    rec["hang"] = HangStatsJson(hung.stats);
    HangCostTiming(hung.stats, timing);
    if (!hung.ok) return fail("hang: " + hung.failure);

    if (std::string why = SenseHung(recipe, sensing, job, *anchor, hung, stage, e); !why.empty()) return fail(why);
  } catch (const NumericalError& err) {
    return fail(std::string("numerical: ") + err.what());
  }
  finish_timing();
  return e;
}

std::string FormatDuration(double s) {
  if (!std::isfinite(s) || s < 0) return "--";
  const long t = std::lround(s);
  char buf[32];
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else if (t >= 60)
    std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%lds", t);
  return buf;
}

void ProgressLine::Print(int done, int total, int failed, double elapsed, double eta, bool over,
                         const std::string& suffix) {
  if (mode_ == ProgressMode::kQuiet) return;
  std::ostringstream line;
  line << "[" << done << "/" << total << "] " << failed << " failed, " << FormatDuration(elapsed) << " elapsed, ETA "
       << (done < total ? FormatDuration(eta) : "0s") << suffix;
  if (mode_ == ProgressMode::kTty) {
    log_ << "\r\033[K" << line.str() << (over ? "\n" : "") << std::flush;
  } else if (done != last_reported_ && (over || Since(last_plain_) >= interval_)) {
    log_ << line.str() << "\n" << std::flush;
    last_plain_ = Clock::now();
    last_reported_ = done;
  }
}

namespace {

Json RecipeSummary(const Recipe& r, const std::vector<Job>& jobs) {
  Json s;
  Json splits = Json::object();
  for (const auto& j : jobs) splits[j.split] = splits.value(j.split, 0) + 1;
  s["jobs"] = jobs.size();
  s["jobs_per_split"] = splits;
  Json garments = Json::array();
  for (const auto& g : r.garments)
    garments.push_back({{"name", g.name},
                        {"template", g.template_name.empty() ? g.file.filename().string() : g.template_name},
                        {"category", g.category},
                        {"instances", g.instances},
                        {"materials", g.materials},
                        {"anchors", g.anchor_labels}});
  s["garments"] = garments;
  Json sensing = Json::object();
  for (const auto& [k, v] : r.sensing)
    sensing[k] = {{"frames", v.sweep.frames},
                  {"degrees", v.sweep.degrees},
                  {"back_and_forth", v.sweep.back_and_forth},
                  {"noise", v.sweep.kinect.noise},
                  {"keep_frames", v.keep_frames}};
  s["sensing"] = sensing;
  s["fusion"] = {{"voxels_per_metre", r.fusion.voxels_per_metre}, {"truncation", r.fusion.Truncation()}};
  s["feature"] = {{"layers", r.feature.layers}, {"rings", r.feature.rings}, {"sectors", r.feature.sectors}};
  if (r.feature.origin != FeatureOptions().origin) s["feature"]["origin"] = r.feature.origin;
  return s;
}

}  // namespace

ReleaseMeta MakeReleaseMeta(const Recipe& recipe, const std::vector<Job>& jobs, const std::vector<int>& shard,
                            const BuildOptions& options) {
  ReleaseMeta meta;
  meta.name = recipe.name;
  meta.version = recipe.version;
  meta.seed = recipe.seed;
  meta.recipe_text = recipe.text;
  meta.code_version = options.code_version.empty() ? std::string(GitVersion()) : options.code_version;
  meta.description = recipe.description;
  meta.license = recipe.license;
  meta.recipe_summary = RecipeSummary(recipe, jobs);
  std::vector<std::pair<std::string, fs::path>> imported;  // copied into the release
  for (const auto& g : recipe.garments) {
    if (!g.file_as_written.empty()) imported.emplace_back(g.file_as_written, g.file);
    if (!g.anchors_as_written.empty()) imported.emplace_back(g.anchors_as_written, g.anchors);
  }
  meta.sources = PlanSources(imported);
  for (const auto& j : jobs) meta.job_keys.push_back(j.key);
  if (options.shard_count > 1)
    for (int i : shard) meta.shard_keys.push_back(jobs[i].key);
  meta.shard_index = options.shard_index - 1;
  meta.shard_count = options.shard_count;
  return meta;
}

void LogStageSeconds(std::ostream& log, const std::map<std::string, double>& stage_seconds) {
  if (stage_seconds.empty()) return;
  // The hang's parts ("hang.<part>", thread CPU) have a line of their own.
  auto part = [](const std::string& k) { return k.rfind("hang.", 0) == 0; };
  double sum = 0;
  for (const auto& [k, v] : stage_seconds)
    if (!part(k)) sum += v;
  log << "stage wall time (summed over jobs):";
  for (const char* k : {"garment", "fit", "hang", "sweep", "fusion", "accuracy", "feature", "encode", "preview"}) {
    auto it = stage_seconds.find(k);
    if (it == stage_seconds.end()) continue;
    log << " " << k << " " << std::fixed << std::setprecision(1) << it->second << "s";
    if (sum > 0) log << " (" << std::lround(100 * it->second / sum) << "%)";
  }
  log << std::defaultfloat << "\n";
  auto get = [&](const char* k) {
    const auto it = stage_seconds.find(std::string("hang.") + k);
    return it == stage_seconds.end() ? 0.0 : it->second;
  };
  if (!stage_seconds.count("hang.cpu")) return;
  const double cpu = get("cpu"), bullet = get("bullet"), collision = get("collision");
  double own = collision, named = 0;
  for (const char* k : {"broad", "strain", "repulsion", "colliders", "ccd", "zones"}) own -= get(k);
  for (const char* k : {"setup", "bullet", "bend", "collision", "step", "settle", "measure"}) named += get(k);
  auto s = [](double v, int digits = 1) {
    std::ostringstream o;
    o << std::fixed << std::setprecision(digits) << v;
    return o.str();
  };
  log << "hang CPU time (summed over jobs): " << s(cpu) << "s = setup " << s(get("setup")) << " + bullet " << s(bullet)
      << " + bend " << s(get("bend")) << " + collision " << s(collision) << " (broad " << s(get("broad")) << ", strain "
      << s(get("strain")) << ", repulsion " << s(get("repulsion")) << ", colliders " << s(get("colliders")) << ", ccd "
      << s(get("ccd")) << ", zones " << s(get("zones")) << ", own " << s(own) << ") + step " << s(get("step"))
      << " + settle " << s(get("settle")) << " + measure " << s(get("measure")) << " + unnamed " << s(cpu - named)
      << "; retried attempts " << s(get("retry")) << "s of it";
  if (bullet > 0)
    log << "; collision " << s(collision / bullet, 2) << "x bullet, hang " << s(cpu / bullet, 2) << "x bullet";
  log << "\n";
}

namespace {

// build.json "costs" of a finalized release: what the entries' timing does not hold
// (cost.h). build.json is never hashed, so it is rewritten here, after Finalize.
void RecordBuildCosts(const fs::path& dir, const BuildReport& report, double finalize_cpu) {
  double viewer_meshes = 0, fixed = 0, per_entry = 0;
  int entries = 0;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    if (ec || !it->is_regular_file()) continue;
    const std::string rel = fs::relative(it->path(), dir).generic_string();
    const double size = static_cast<double>(it->file_size());
    if (rel.rfind("entries/", 0) == 0) {
      if (it->path().filename() == "entry.json") per_entry += size, ++entries;  // the other files: entry timing
    } else if (rel.rfind("viewer/meshes/", 0) == 0) {
      viewer_meshes += size;
    } else if (rel == "catalog.sqlite" || rel == "index.html" || rel == "SHA256SUMS" || rel == "build.json") {
      per_entry += size;
    } else {
      fixed += size;  // the viewer's libraries, README.md, dataset.json, sources/
    }
  }
  Json costs{
      {"entries", entries},
      {"commit_cpu_seconds", report.commit_cpu_seconds},
      {"finalize_cpu_seconds", finalize_cpu},
      {"probe_cpu_seconds", SpeedProbeCpuSeconds()},
      {"bytes", {{"viewer_meshes", viewer_meshes}, {"fixed", fixed}, {"per_entry", per_entry / std::max(1, entries)}}},
  };
  const Json dataset = Release::Open(dir).dataset();
  costs["release"] = dataset.value("name", "") + " " + dataset.value("version", "");
  const fs::path p = dir / "build.json";
  Json build = Json::parse(ReadFile(p));
  build["costs"] = costs;
  WriteFileAtomic(p, build.dump(1) + "\n");
}

}  // namespace

void FinishBuild(ReleaseWriter& writer, BuildReport& report, ProgressMode mode, std::ostream& log) {
  report.interrupted = !report.aborted && report.already_done + report.built < report.shard_jobs;
  writer.SetBuildInfo("stage_seconds", Json(report.stage_seconds));
  writer.SetBuildInfo("provenance", RunProvenance());
  if (mode != ProgressMode::kQuiet) LogStageSeconds(log, report.stage_seconds);
  if (report.aborted || report.interrupted) return;
  const double c0 = ProcessCpuSeconds();
  const auto summary = writer.Finalize();
  RecordBuildCosts(report.output, report, ProcessCpuSeconds() - c0);
  report.finalized = true;
  report.digest = summary.digest;
  report.release_failed = summary.failed;
  if (mode == ProgressMode::kQuiet) return;
  log << "release " << report.output.string() << ": " << summary.entries << " entries, " << summary.failed
      << " failed, digest " << summary.digest << "\n";
  if (!summary.published_digest.empty())
    log << (summary.matches_published ? "matches" : "DIFFERS FROM") << " the published digest "
        << summary.published_digest << "\n";
}

namespace {

// BuildEntry, or with keep_going a failed entry carrying the error; nullopt (and
// *error) when the error stops the build.
std::optional<Entry> BuildOrFailEntry(const Recipe& recipe, const Job& job, JobCache& cache, bool keep_going,
                                      std::string* error) {
  try {
    return BuildEntry(recipe, job, cache);
  } catch (const std::exception& ex) {
    *error = ex.what();
    if (!keep_going) return std::nullopt;
    return FailedEntry(job, ex.what());
  }
}

}  // namespace

Entry FailedEntry(const Job& job, const std::string& error) {
  Entry entry;
  entry.id = job.id;
  entry.key = job.key;
  entry.split = job.split;
  entry.failed = true;
  entry.failure = "error: " + error;
  entry.record = {{"seed", job.seed}};
  return entry;
}

void CountEntry(const Entry& entry, const Job& job, BuildReport& report) {
  ++report.built;
  if (entry.failed) {
    ++report.failed;
    report.failures.push_back({job.key, entry.failure});
  }
  for (auto it = entry.timing.begin(); it != entry.timing.end(); ++it)
    if (it->is_number() && it.key() != "total" && it.key() != "mpi_rank")
      report.stage_seconds[it.key()] += it->get<double>();
}

BuildStart StartBuild(const Recipe& recipe, const BuildOptions& options, BuildReport& report) {
  BuildStart start;
  report.output = options.output.empty() ? DefaultOutput(recipe) : options.output;
  start.jobs = ExpandJobs(recipe);
  report.total_jobs = static_cast<int>(start.jobs.size());
  const std::vector<int> shard = ShardJobs(report.total_jobs, options.shard_index, options.shard_count);
  report.shard_jobs = static_cast<int>(shard.size());
  start.writer =
      ReleaseWriter::Open(report.output, MakeReleaseMeta(recipe, start.jobs, shard, options), options.resume);
  const std::set<std::string> done = start.writer->DoneKeys();
  for (int i : shard)
    if (!done.count(start.jobs[i].key)) start.todo.push_back(i);
  report.already_done = report.shard_jobs - static_cast<int>(start.todo.size());
  return start;
}

EtaClock MakeEtaClock(const Recipe& recipe, const BuildStart& start, int workers, const BuildOptions& options) {
  std::vector<double> predicted(start.todo.size(), 0.0);
  if (options.costs && !options.costs->empty())
    predicted = PlanBuild(recipe, start.jobs, start.todo, workers, *options.costs).job_cpu;
  return EtaClock(std::move(predicted), workers);
}

ProgressMode ResolveProgressMode(ProgressMode mode, const std::ostream& log) {
  if (mode != ProgressMode::kAuto) return mode;
  return (&log == &std::cerr && isatty(STDERR_FILENO)) || (&log == &std::cout && isatty(STDOUT_FILENO))
             ? ProgressMode::kTty
             : ProgressMode::kPlain;
}

void LogBuildStart(std::ostream& log, const Recipe& recipe, const BuildOptions& options, const BuildReport& report,
                   size_t todo) {
  log << "drape build: " << recipe.name << " " << recipe.version << " → " << report.output.string() << "\n"
      << "  " << report.total_jobs << " jobs";
  if (options.shard_count > 1)
    log << ", shard " << options.shard_index << "/" << options.shard_count << ": " << report.shard_jobs;
  if (report.already_done) log << ", " << report.already_done << " already done (resuming)";
  log << ", " << todo << " to run on ";
}

namespace {

// What the job threads share with the thread that prints progress (under mu).
struct JobsState {
  explicit JobsState(EtaClock eta) : eta(std::move(eta)) {}
  std::mutex mu;
  std::condition_variable cv;
  std::atomic<bool> abort{false};
  int finished = 0, running = 0;
  EtaClock eta;       // the finished jobs' wall times against their price
  bool over = false;  // every job handed out has returned
};

// Prints progress (and the interrupt note) until every job handed out has returned.
void WatchJobs(JobsState& st, std::ostream& log, ProgressMode mode, const BuildOptions& options,
               const BuildReport& report, Clock::time_point t0) {
  std::unique_lock<std::mutex> lock(st.mu);
  ProgressLine progress(log, mode, options.progress_interval);
  bool stop_noted = false;
  for (;;) {
    const bool last = st.over;
    const double eta = st.eta.Remaining();
    if (options.stop && options.stop->load() && !stop_noted && mode != ProgressMode::kQuiet) {
      stop_noted = true;
      log << (mode == ProgressMode::kTty ? "\n" : "") << "drape build: interrupted; letting " << st.running
          << " running job(s) finish and commit (Ctrl-C again quits at once; --resume continues)\n";
    }
    progress.Print(report.already_done + st.finished, report.shard_jobs, report.failed, Since(t0), eta, last);
    if (last) break;
    st.cv.wait_for(lock, std::chrono::milliseconds(500));
  }
}

}  // namespace

BuildReport RunBuild(const Recipe& recipe, const BuildOptions& options) {
  const auto t0 = Clock::now();
  std::ostream& log = options.log ? *options.log : std::cerr;
  BuildReport report;
  BuildStart start = StartBuild(recipe, options, report);
  const std::vector<Job>& jobs = start.jobs;
  const std::vector<int>& todo = start.todo;
  std::unique_ptr<ReleaseWriter>& writer = start.writer;
  const size_t wanted = std::max(1, options.threads > 0 ? options.threads : HardwareThreads());
  const int threads = static_cast<int>(std::min(wanted, std::max<size_t>(1, todo.size())));
  const ProgressMode mode = ResolveProgressMode(options.progress, log);
  if (mode != ProgressMode::kQuiet) {
    LogBuildStart(log, recipe, options, report, todo.size());
    log << threads << " thread" << (threads > 1 ? "s" : "") << "\n";
    log.flush();
  }

  JobCache cache;
  JobsState st(MakeEtaClock(recipe, start, threads, options));

  auto stopping = [&] { return st.abort.load() || (options.stop && options.stop->load()); };
  // One job: build, commit, count. An error stops handing out jobs (unless keep_going).
  auto run_job = [&](int k) {
    if (stopping()) return;
    const Job& job = jobs[todo[k]];
    {
      std::lock_guard<std::mutex> lock(st.mu);
      ++st.running;
    }
    const auto tj = Clock::now();
    std::string error;
    std::optional<Entry> entry = BuildOrFailEntry(recipe, job, cache, options.keep_going, &error);
    const double c0 = ThreadCpuSeconds();
    if (entry) {
      try {
        writer->Commit(*entry);
      } catch (const std::exception& ex) {
        entry.reset();
        error = std::string("committing ") + job.key + ": " + ex.what();
      }
    }
    const double commit_cpu = ThreadCpuSeconds() - c0;
    std::lock_guard<std::mutex> lock(st.mu);
    --st.running;
    if (!entry) {
      if (!st.abort.exchange(true)) report.error = job.key + ": " + error;
      report.aborted = true;
    } else {
      ++st.finished;
      st.eta.Done(k, Since(tj));
      report.commit_cpu_seconds += commit_cpu;
      CountEntry(*entry, job, report);
    }
    st.cv.notify_all();
  };
  // The jobs run on common/parallel's pool; this thread only watches and prints.
  std::thread jobs_thread([&] {
    ParallelFor(static_cast<int>(todo.size()), threads, run_job);
    std::lock_guard<std::mutex> lock(st.mu);
    st.over = true;
    st.cv.notify_all();
  });

  WatchJobs(st, log, mode, options, report, t0);
  jobs_thread.join();

  writer->SetBuildInfo("threads", threads);
  // This process's CPU over the run (all its threads): what the build cost on a shared machine.
  writer->SetBuildInfo("cpu_seconds", ProcessCpuSeconds());
  FinishBuild(*writer, report, mode, log);
  report.wall_seconds = Since(t0);
  return report;
}

}  // namespace drape
