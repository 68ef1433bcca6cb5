// End-to-end builds of a tiny recipe (two coarse towel jobs, few frames, low voxel
// density) through every stage and the release writer. Slow-ish: tens of seconds.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/files.h"
#include "garments/io.h"
#include "garments/templates.h"
#include "generator/pipeline/build.h"
#include "generator/release/release.h"

namespace fs = std::filesystem;
namespace drape {
namespace {

// The small, fast settings every recipe here shares (after its name).
const std::string kFastSettings = R"(
version: 0.0.1
seed: 5
simulation: {time_cap: 8}
sensing:
  database: {frames: 8, noise: false}
  sensed: {frames: 8}
fusion: {voxels_per_metre: 80}
feature: {layers: 8, rings: 8, sectors: 8}
)";

const std::string kTiny = "name: tiny" + kFastSettings + R"(garments:
  - template: towel
    instances: 2
    edge_length: 0.05
    params: {width: 0.4, length: 0.5}
    materials: [towel_a]
    anchors: [top_left]
splits:
  train:
    garments: [{garment: towel, instances: [0]}]
  test:
    garments: [{garment: towel, instances: [1]}]
    perturbation: {grasp_offset: 0.02}
)";

fs::path TempDir(const std::string& tag) {
  fs::path d = fs::temp_directory_path() / ("drape_pipeline_test_" + std::to_string(::getpid()) + "_" + tag);
  fs::remove_all(d);
  return d;
}

BuildReport Build(const Recipe& r, const fs::path& out, int threads, const std::atomic<bool>* stop = nullptr) {
  BuildOptions o;
  o.output = out;
  o.threads = threads;
  o.progress = ProgressMode::kQuiet;
  o.stop = stop;
  o.code_version = "test";
  return RunBuild(r, o);
}

TEST(Build, PreviewIsAThreePanelPng) {
  TriMesh m;
  m.V.resize(3, 3);
  m.V << 0, 0, 0, 0.1, -0.3, 0, -0.1, -0.3, 0.01;
  m.F.resize(1, 3);
  m.F << 0, 1, 2;
  const std::string png = RenderEntryPreview(m, Vec3::Zero(), "", m, "title");
  std::vector<uchar> buf(png.begin(), png.end());
  const cv::Mat img = cv::imdecode(buf, cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 3 * 360);
  EXPECT_EQ(png, RenderEntryPreview(m, Vec3::Zero(), "", m, "title"));
}

// One job through every stage; -j1 and -j2 builds give the same digest and entries;
// an interrupted build resumes to the same digest.
TEST(Build, TinyRecipeEndToEndIsDeterministicAcrossThreadsAndResume) {
  const Recipe r = ParseRecipe(kTiny, "tiny.yaml", fs::temp_directory_path());
  const auto jobs = ExpandJobs(r);
  ASSERT_EQ(jobs.size(), 2u);

  JobCache cache;
  const Entry e = BuildEntry(r, jobs[0], cache);
  ASSERT_FALSE(e.failed) << e.failure;
  std::set<std::string> files;
  for (const auto& f : e.files) files.insert(f.path);
  for (const char* f : {"hang.ply", "recon.ply", "sdf.vdb", "feature.bin", "preview.png"})
    EXPECT_TRUE(files.count(f)) << f;
  EXPECT_EQ(e.record["anchor"]["label"], "top_left");
  EXPECT_EQ(e.record["feature"]["layers"], 8);
  EXPECT_GT(e.record["fusion"]["recon_to_truth_mean"].get<double>(), 0.0);
  EXPECT_LT(e.record["fusion"]["recon_to_truth_mean"].get<double>(), 0.05);  // 80 voxels/m: within a few voxels
  EXPECT_TRUE(e.timing.contains("hang"));

  const fs::path a = TempDir("j1"), b = TempDir("j2"), c = TempDir("resume");
  const BuildReport ra = Build(r, a, 1);
  ASSERT_TRUE(ra.finalized) << ra.error;
  EXPECT_EQ(ra.built, 2);
  const BuildReport rb = Build(r, b, 2);
  ASSERT_TRUE(rb.finalized) << rb.error;
  EXPECT_EQ(ra.digest, rb.digest);
  const Release rela = Release::Open(a), relb = Release::Open(b);
  ASSERT_EQ(rela.entries().size(), 2u);
  const auto diff = CompareReleases(rela, relb);
  EXPECT_TRUE(diff.same());
  EXPECT_EQ(rela.entries()[0].id, jobs[0].id);
  EXPECT_EQ(rela.entries()[1].split, "test");

  // Stopped before any job: nothing finalized; the next run resumes and finishes.
  std::atomic<bool> stop{true};
  const BuildReport rc1 = Build(r, c, 2, &stop);
  EXPECT_TRUE(rc1.interrupted);
  EXPECT_FALSE(rc1.finalized);
  const BuildReport rc2 = Build(r, c, 1);
  ASSERT_TRUE(rc2.finalized) << rc2.error;
  EXPECT_EQ(rc2.digest, ra.digest);

  // Shards 1/2 and 2/2 merged give the one-process digest.
  const fs::path s1 = TempDir("s1"), s2 = TempDir("s2"), merged = TempDir("merged");
  for (int k = 1; k <= 2; ++k) {
    BuildOptions o;
    o.output = k == 1 ? s1 : s2;
    o.threads = 1;
    o.shard_index = k;
    o.shard_count = 2;
    o.progress = ProgressMode::kQuiet;
    o.code_version = "test";
    const BuildReport rs = RunBuild(r, o);
    ASSERT_TRUE(rs.finalized) << rs.error;
    EXPECT_EQ(rs.shard_jobs, 1);
  }
  const auto summary = Merge({s1, s2}, merged);
  EXPECT_EQ(summary.digest, ra.digest);
  for (const auto& d : {a, b, c, s1, s2, merged}) fs::remove_all(d);
}

// hangs_per_anchor: 2 stores the anchor's own hang (hang 0) byte for byte as the K = 1
// build does, and a second hang of the same label with its variation recorded.
TEST(Build, HangsPerAnchorKeepHangZeroAndRecordTheVariation) {
  const Recipe r1 = ParseRecipe(kTiny, "tiny.yaml", fs::temp_directory_path());
  std::string k2 = kTiny;
  const std::string train = "    garments: [{garment: towel, instances: [0]}]\n";
  k2.replace(k2.find(train), train.size(),
             train +
                 "    hangs_per_anchor: 2\n"
                 "    hang_variation: {grasp_miss: 0.01, material_jitter: 0.1, pickup_spin: 1}\n");
  const Recipe r2 = ParseRecipe(k2, "tiny.yaml", fs::temp_directory_path());
  const auto jobs1 = ExpandJobs(r1), jobs2 = ExpandJobs(r2);
  ASSERT_EQ(jobs2.size(), 3u);
  JobCache cache1, cache2;
  const Entry one = BuildEntry(r1, jobs1[0], cache1);
  const Entry h0 = BuildEntry(r2, jobs2[0], cache2);
  const Entry h1 = BuildEntry(r2, jobs2[1], cache2);
  ASSERT_FALSE(one.failed) << one.failure;
  ASSERT_FALSE(h0.failed) << h0.failure;
  ASSERT_FALSE(h1.failed) << h1.failure;
  EXPECT_EQ(h0.id, one.id);
  EXPECT_EQ(h0.record, one.record);
  ASSERT_EQ(h0.files.size(), one.files.size());
  for (size_t i = 0; i < one.files.size(); ++i) {
    EXPECT_EQ(h0.files[i].path, one.files[i].path);
    EXPECT_TRUE(h0.files[i].bytes == one.files[i].bytes) << one.files[i].path;
  }
  EXPECT_FALSE(h0.record.contains("hang_index"));
  EXPECT_EQ(h1.key, one.key + "/h1");
  EXPECT_EQ(h1.record["anchor"]["label"], "top_left");
  EXPECT_EQ(h1.record["hang_index"], 1);
  const Json& v = h1.record["hang_variation"];
  EXPECT_EQ(v["grasp_miss"][0].get<double>(), jobs2[1].hang_miss.x());
  EXPECT_EQ(v["material_jitter"][3].get<double>(), jobs2[1].hang_material_jitter[3]);
  EXPECT_EQ(v["pickup_spin"][2].get<double>(), jobs2[1].pickup_spin.z());
  bool same_hang = true;
  for (size_t i = 0; i < h1.files.size(); ++i)
    if (h1.files[i].path == "hang.ply") same_hang = h1.files[i].bytes == one.files[i].bytes;
  EXPECT_FALSE(same_hang);  // another draw of the fall
}

// A recipe importing meshes/cloth.EXT (+ its anchors sidecar).
std::string ImportedRecipe(const std::string& ext) {
  return "name: imported" + kFastSettings + R"(garments:
  - file: meshes/cloth.)" +
         ext + R"(
    anchors_file: meshes/cloth.anchors.json
    category: towel
    materials: [towel_a]
    anchors: [top_left]
splits:
  train:
    garments: [{garment: cloth, instances: [0]}]
)";
}

// A release built from an imported mesh carries the mesh, the files it refers to (an
// .obj's .mtl, a .gltf's .bin) and its sidecar (hashed, in SHA256SUMS and the digest);
// moved away from the recipe's folder it still verifies, re-reads its recipe from its
// own copies and rebuilds to the same digest.
void ExpectSelfContained(const std::string& ext, const std::string& companion) {
  SCOPED_TRACE(ext);
  const fs::path src = TempDir("import_src"), out = TempDir("import_out"), moved = TempDir("import_moved"),
                 again = TempDir("import_again");
  TemplateOptions to;
  to.edge_length = 0.05;
  to.params = {{"width", 0.4}, {"length", 0.5}};
  fs::create_directories(src / "meshes");
  const std::string mesh = "meshes/cloth." + ext;
  ExportGarment(MakeGarment("towel", to), src / mesh);
  ASSERT_TRUE(fs::exists(src / companion));  // what assimp's exporter writes beside the mesh
  WriteFileAtomic(src / "recipe.yaml", ImportedRecipe(ext));
  const Recipe r = LoadRecipe(src / "recipe.yaml");
  const BuildReport built = Build(r, out, 1);
  ASSERT_TRUE(built.finalized) << built.error;
  {
    const Release rel = Release::Open(out);
    ASSERT_EQ(rel.SourceFiles().size(), 3u);
    EXPECT_EQ(rel.SourceFiles().at(mesh), out / "sources" / mesh);
    EXPECT_EQ(rel.SourceFiles().at(companion), out / "sources" / companion);
    for (const std::string& f : {mesh, companion, std::string("meshes/cloth.anchors.json")})
      EXPECT_EQ(ReadFile(out / "sources" / f), ReadFile(src / f)) << f;
    const std::string sums = ReadFile(out / "SHA256SUMS");
    EXPECT_NE(sums.find("  sources/" + mesh + "\n"), std::string::npos) << sums;
    EXPECT_NE(sums.find("  sources/" + companion + "\n"), std::string::npos) << sums;
    EXPECT_NE(rel.digest(), ComputeDigest(rel.entries()));  // the sources are in the digest
  }
  fs::rename(out, moved);
  fs::remove_all(src);
  EXPECT_TRUE(Verify(moved).ok());
  const Release rel = Release::Open(moved);
  const std::string text = rel.dataset()["recipe"]["text"];
  const Recipe rr = ParseRecipe(text, "dataset.json (recipe)", moved, &rel.SourceFiles());
  EXPECT_EQ(rr.garments[0].file, moved / "sources" / mesh);
  const BuildReport rebuilt = Build(rr, again, 1);
  ASSERT_TRUE(rebuilt.finalized) << rebuilt.error;
  EXPECT_EQ(rebuilt.digest, built.digest);
  EXPECT_EQ(ReadFile(again / "SHA256SUMS"), ReadFile(moved / "SHA256SUMS"));
  // A changed copy is caught by verify (hash and digest), the companion as well.
  WriteFileAtomic(moved / "sources/meshes/cloth.anchors.json", "{}");
  WriteFileAtomic(moved / "sources" / companion, "changed");
  const VerifyReport v = Verify(moved);
  std::vector<std::string> changed = {"sources/meshes/cloth.anchors.json", "sources/" + companion};
  std::vector<std::string> got = v.changed;
  std::sort(changed.begin(), changed.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, changed);
  EXPECT_NE(v.actual_digest, v.expected_digest);
  for (const auto& d : {moved, again}) fs::remove_all(d);
}

TEST(Build, ImportedObjReleaseIsSelfContained) { ExpectSelfContained("obj", "meshes/cloth.mtl"); }

// glTF keeps its geometry in a .bin beside it: without the copy, a moved release could
// not re-read its mesh (the rebuild above would fail).
TEST(Build, ImportedGltfReleaseIsSelfContained) { ExpectSelfContained("gltf", "meshes/cloth.bin"); }

}  // namespace
}  // namespace drape
