// Recognition against real release folders written with the release writer API
// (synthetic features, no physics).
#include "runtime/recognition/release_source.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "common/error.h"
#include "common/files.h"
#include "common/rng.h"
#include "garments/mesh_read.h"
#include "generator/feature/feature.h"
#include "runtime/recognition/test_features.h"

namespace drape::recognition {
namespace {

namespace fs = std::filesystem;

// Binary PLY with 3 float vertices, vertex i at (i, -i, 0.5 i) / 10.
std::string TinyPly() {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 3; ++i) {
    const float v[3] = {i / 10.0f, -i / 10.0f, 0.05f * i};
    s.append(reinterpret_cast<const char*>(v), sizeof v);
  }
  return s;
}

// The same three vertices as an ascii PLY with one face, and as a big-endian binary PLY
// (which the minimal vertex reader leaves to the full reader).
std::string TinyPlyAscii() {
  return "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
         "0 0 0\n0.1 -0.1 0.05\n0.2 -0.2 0.1\n3 0 1 2\n";
}
std::string TinyPlyBigEndian() {
  std::string s =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 3; ++i) {
    const float v[3] = {i / 10.0f, -i / 10.0f, 0.05f * i};
    for (float f : v) {
      char b[4];
      std::memcpy(b, &f, 4);
      s.append({b[3], b[2], b[1], b[0]});
    }
  }
  return s;
}

struct Spec {
  std::string split, category, instance, anchor;
  Feature feature;
};

// shirt: instances shirt-1, shirt-2 in train, 4 anchors; pants: one train instance, 3
// anchors. Calibration: shirt-c (anchor a3 missing), pants-c. Test: rotated, noisy copies.
std::vector<Spec> MakeSpecs(uint64_t seed, bool with_train = true) {
  Rng rng(seed);
  std::vector<Spec> specs;
  std::map<std::string, Feature> proto;
  const std::vector<std::pair<std::string, int>> cats = {{"shirt", 4}, {"pants", 3}};
  for (const auto& [cat, n] : cats) {
    for (int a = 0; a < n; ++a) proto[cat + "/a" + std::to_string(a)] = RandomFeature(rng);
  }
  for (const auto& [cat, n] : cats) {
    for (int a = 0; a < n; ++a) {
      const std::string an = "a" + std::to_string(a);
      const Feature& p = proto[cat + "/" + an];
      if (with_train) {
        specs.push_back({"train", cat, cat + "-1", an, FlipBits(p, rng, 6)});
        if (cat == "shirt") specs.push_back({"train", cat, cat + "-2", an, FlipBits(p, rng, 6)});
      }
      if (!(cat == "shirt" && a == 3)) specs.push_back({"calibration", cat, cat + "-c", an, FlipBits(p, rng, 12)});
      specs.push_back({"test", cat, cat + "-t", an, Rotate(FlipBits(p, rng, 12), a + 1)});
    }
  }
  return specs;
}

fs::path BuildRelease(const fs::path& dir, const std::vector<Spec>& specs, const std::string& name) {
  fs::remove_all(dir);
  ReleaseMeta m;
  m.name = name;
  m.version = "1.0.0";
  m.seed = 1;
  m.recipe_text = "name: " + name + "\n";
  m.code_version = "test";
  for (size_t i = 0; i < specs.size(); ++i) m.job_keys.push_back("job" + std::to_string(i));
  auto w = ReleaseWriter::Open(dir, m);
  for (size_t i = 0; i < specs.size(); ++i) {
    const Spec& s = specs[i];
    Entry e;
    e.id = "e" + std::string(i < 10 ? "00" : i < 100 ? "0" : "") + std::to_string(i);
    e.key = m.job_keys[i];
    e.split = s.split;
    const int a = s.anchor.back() - '0';
    e.record = Json{{"category", s.category},
                    {"instance", s.instance},
                    {"material", "tshirt"},
                    {"anchor", {{"label", s.anchor}, {"vertex", a % 3}, {"uv", {0.1 * a, 0.0}}}}};
    e.timing = Json{{"stages", {{"fusion_seconds", 0.25}, {"feature_seconds", 0.002}}}};
    e.files.push_back({"hang.ply", TinyPly()});
    e.files.push_back({"recon.ply", i % 3 == 0 ? TinyPly() : i % 3 == 1 ? TinyPlyAscii() : TinyPlyBigEndian()});
    e.files.push_back({"feature.bin", EncodeFeature(s.feature)});
    w->Commit(e);
  }
  w->Finalize();
  return dir;
}

class RecognitionRelease : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("drape_recognition_release_" + std::to_string(::getpid()));
    specs_ = MakeSpecs(5);
    BuildRelease(root_ / "a", specs_, "synth");
  }
  static void TearDownTestSuite() {
    if (!std::getenv("DRAPE_KEEP_TEST_OUTPUT")) fs::remove_all(root_);
  }
  static inline fs::path root_;
  static inline std::vector<Spec> specs_;
};

TEST_F(RecognitionRelease, LoadsTheTrainSplitWithLabels) {
  const Release rel = Release::Open(root_ / "a");
  LoadReport lr;
  const Database db = LoadDatabase(rel, &lr);
  EXPECT_EQ(db.size(), 11);  // shirt 2×4 + pants 3
  EXPECT_EQ(lr.loaded, 11);
  EXPECT_EQ(db.categories(), (std::vector<std::string>{"pants", "shirt"}));
  EXPECT_EQ(db.instances("shirt"), (std::vector<std::string>{"shirt-1", "shirt-2"}));
  EXPECT_EQ(db.instances("pants"), (std::vector<std::string>{"pants-1"}));
  const EntryLabel& l = db.label(0);
  EXPECT_EQ(l.split, "train");
  ASSERT_TRUE(l.anchor_uv.has_value());
  // The fast matcher agrees with the feature library's Eq. match on release features.
  const std::vector<LabelledCode> test = LoadSplit(rel, "test", nullptr);
  ASSERT_EQ(test.size(), 7u);
  std::vector<Match> got;
  for (const auto& q : test) {
    db.matcher().MatchAll(PreparedQuery(q.code), &got);
    const Feature fq = DecodeFeature(rel.ReadFile(q.label.id, "feature.bin"), q.label.id);
    for (int i = 0; i < db.size(); ++i) {
      const Feature fx = DecodeFeature(rel.ReadFile(db.label(i).id, "feature.bin"), db.label(i).id);
      const drape::Match ref = Distance(fx, fq);
      ASSERT_EQ(got[i].distance, ref.distance);
      ASSERT_EQ(got[i].rotation, ref.rotation);
    }
  }
  // Hung heights from recon.ply (binary, ascii, big-endian), as the full reader sees them.
  for (const auto& lc : test) {
    const MeshData m = ParsePly(rel.ReadFile(lc.label.id, "recon.ply"), lc.label.id);
    double lo = 1e9, hi = -1e9;
    for (const Vec3& v : m.V) lo = std::min(lo, v.y()), hi = std::max(hi, v.y());
    EXPECT_NEAR(lc.label.height, hi - lo, 1e-7) << lc.label.id;
    EXPECT_NEAR(lc.label.height, 0.2, 1e-7) << lc.label.id;
  }
  // Hung anchor position from hang.ply.
  const auto p = HungVertex(rel, db.label(0).id, 2);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR((*p)[0], 0.2, 1e-6);
  EXPECT_NEAR((*p)[1], -0.2, 1e-6);
  EXPECT_NEAR((*p)[2], 0.1, 1e-6);
  const StageTiming t = EntryStageTiming(rel.build_info(), test[0].label.id);
  EXPECT_DOUBLE_EQ(t.fusion_seconds, 0.25);
  EXPECT_DOUBLE_EQ(t.feature_seconds, 0.002);
}

TEST_F(RecognitionRelease, CalibrateEvaluateAndRefuseForeignWeights) {
  const Release rel = Release::Open(root_ / "a");
  const Database db = LoadDatabase(rel, nullptr);
  const std::vector<LabelledCode> calib = LoadSplit(rel, "calibration", nullptr);
  const CalibrationResult res = Calibrate(db, calib, {}, rel.digest());
  EXPECT_EQ(res.weights.per_category.size(), 2u);
  SaveWeights(res.weights, DefaultWeightsDir(rel));
  const Weights w = LoadWeights(DefaultWeightsDir(rel), rel.digest());
  EXPECT_EQ(w.per_category.at("shirt"), res.weights.per_category.at("shirt"));

  // Eval end to end: every test query is a noisy, turned copy; all recognised.
  const std::vector<EvalQuery> qs = LoadEvalQueries(rel, "test", nullptr);
  const EvalResult er = Evaluate(db, &w, qs, AnchorUvs(rel), {});
  EXPECT_DOUBLE_EQ(er.report["overall"]["pose_accuracy"]["both"]["learned"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(er.report["overall"]["pose_accuracy"]["both"]["unweighted"].get<double>(), 1.0);
  EXPECT_EQ(er.report["overall"]["seconds_per_query"]["fusion_known"], 7);
  const fs::path report = root_ / "report";
  WriteReport(er, Json{{"release", rel.dir().string()}}, report);
  EXPECT_TRUE(fs::exists(report / "confusion_shirt.png"));

  // Another release (different content → different digest) refuses these weights.
  BuildRelease(root_ / "b", MakeSpecs(6), "synth");
  const Release other = Release::Open(root_ / "b");
  ASSERT_NE(other.digest(), rel.digest());
  try {
    LoadWeights(DefaultWeightsDir(rel), other.digest());
    FAIL() << "foreign weights accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("learned on release digest " + rel.digest()), std::string::npos) << e.what();
  }
}

TEST_F(RecognitionRelease, CorruptFeatureAndEmptyDatabaseAreClearErrors) {
  const fs::path dir = BuildRelease(root_ / "c", specs_, "synth");
  const Release rel = Release::Open(dir);
  const std::string victim = rel.entries().front().id;  // a train entry
  ASSERT_EQ(rel.entries().front().split, "train");
  std::string bytes = ReadFile(rel.EntryPath(victim, "feature.bin"));
  bytes.resize(bytes.size() - 5);
  WriteFileAtomic(rel.EntryPath(victim, "feature.bin"), bytes);
  try {
    LoadDatabase(rel, nullptr);
    FAIL() << "corrupt feature accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("corrupt feature file"), std::string::npos) << m;
    EXPECT_NE(m.find(victim), std::string::npos) << m;
  }

  const fs::path empty = BuildRelease(root_ / "d", MakeSpecs(7, /*with_train=*/false), "synth");
  try {
    LoadDatabase(Release::Open(empty), nullptr);
    FAIL() << "empty database accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no usable train entries"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace drape::recognition
