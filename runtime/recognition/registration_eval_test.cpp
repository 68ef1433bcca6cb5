// Registration table of `drape eval` on a tiny synthetic release: the test entries'
// recon.ply (and hang.ply) are known rigid motions of the database hang.ply, so the
// rigid errors and the anchor transfer error must be ~0.
#include "runtime/recognition/registration_eval.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/rng.h"
#include "garments/io.h"
#include "generator/feature/feature.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/release_source.h"
#include "runtime/recognition/test_features.h"

namespace drape::recognition {
namespace {

namespace fs = std::filesystem;

// A curved, asymmetric sheet hanging below the origin (object frame), 10 × 14 vertices.
TriMesh Sheet() {
  const int nx = 10, ny = 14;
  TriMesh m;
  m.V.resize(Eigen::Index{nx} * ny, 3);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double x = -0.12 + 0.3 * i / (nx - 1), y = -0.45 * j / (ny - 1);
      m.V.row(j * nx + i) << x + 0.02 * y * y, y, 0.06 * std::sin(9 * x + 2) * (0.3 - y) + 0.04 * x * y;
    }
  }
  m.F.resize(2 * Eigen::Index{nx - 1} * (ny - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      m.F.row(f++) << a, c, b;
      m.F.row(f++) << b, c, d;
    }
  }
  return m;
}

TriMesh Moved(const TriMesh& m, double degrees_about_y, const Vec3& t) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(degrees_about_y * M_PI / 180, Vec3::UnitY()).toRotationMatrix();
  TriMesh o = m;
  for (int i = 0; i < o.NumVertices(); ++i) o.V.row(i) = (r * m.V.row(i).transpose() + t).transpose();
  return o;
}

constexpr int kAnchorVertex = 3;  // on the top row

fs::path BuildRelease(const fs::path& dir) {
  fs::remove_all(dir);
  const TriMesh sheet = Sheet();
  struct Spec {
    std::string split, instance;
    TriMesh hang, recon;
  };
  const std::vector<Spec> specs = {
      {"train", "sheet/i0", sheet, sheet},
      {"test", "sheet/i1", Moved(sheet, 6, Vec3(0.004, -0.003, 0.002)), Moved(sheet, 6, Vec3(0.004, -0.003, 0.002))},
      {"test", "sheet/i2", Moved(sheet, -4, Vec3(-0.002, 0.001, 0.003)), Moved(sheet, -4, Vec3(-0.002, 0.001, 0.003))},
  };
  ReleaseMeta m;
  m.name = "regsynth";
  m.version = "1.0.0";
  m.seed = 1;
  m.recipe_text = "name: regsynth\n";
  m.code_version = "test";
  for (size_t i = 0; i < specs.size(); ++i) m.job_keys.push_back("job" + std::to_string(i));
  auto w = ReleaseWriter::Open(dir, m);
  for (size_t i = 0; i < specs.size(); ++i) {
    Entry e;
    e.id = "e" + std::to_string(i);
    e.key = m.job_keys[i];
    e.split = specs[i].split;
    e.record = Json{{"category", "sheet"},
                    {"instance", specs[i].instance},
                    {"material", "towel_b"},
                    {"anchor", {{"label", "top"}, {"vertex", kAnchorVertex}, {"uv", {0.0, 0.0}}}}};
    e.files.push_back({"hang.ply", EncodeMesh(specs[i].hang)});
    e.files.push_back({"recon.ply", EncodeMesh(specs[i].recon)});
    e.files.push_back({"feature.bin", EncodeFeature(RandomFeature(uint64_t(i + 1)))});
    w->Commit(e);
  }
  w->Finalize();
  return dir;
}

TEST(RegistrationEval, RigidCopiesRegisterToZeroErrorAndTheReportHasTheTable) {
  const fs::path root = fs::temp_directory_path() / ("drape_registration_eval_" + std::to_string(::getpid()));
  const Release rel = Release::Open(BuildRelease(root / "rel"));
  const Database db = LoadDatabase(rel, nullptr);

  RegistrationEvalOptions o;
  o.threads = 1;
  const RegistrationEvalResult r = EvaluateRegistration(rel, db, Json(), "test", o);
  const Json& t = r.table;
  ASSERT_EQ(t["pairs"].size(), 2u);
  EXPECT_EQ(t["failed"], 0);
  for (const Json& p : t["pairs"]) {
    EXPECT_TRUE(p["ok"].get<bool>()) << p.dump();
    EXPECT_EQ(p["source"], "e0");
    EXPECT_EQ(p["source_choice"], "first_instance");
    // Known rigid motion: R recovers it (the sheet is 0.3 × 0.45 m; measured ~2e-6 m
    // and ~0.003 cm; bounds leave a margin of ~50× / ~15×).
    EXPECT_LT(p["s_to_t_rigid"].get<double>(), 1e-4) << p.dump();
    EXPECT_LT(p["t_to_s_rigid"].get<double>(), 1e-4) << p.dump();
    EXPECT_LT(p["s_to_t_nonrigid"].get<double>(), 1e-4) << p.dump();
    EXPECT_LT(p["t_to_s_nonrigid"].get<double>(), 1e-4) << p.dump();
    EXPECT_LT(p["anchor_error_cm"]["rigid"].get<double>(), 0.05) << p.dump();
    EXPECT_LT(p["anchor_error_cm"]["nonrigid"].get<double>(), 0.05) << p.dump();
  }
  EXPECT_EQ(t["average"]["pairs"], 2);
  EXPECT_EQ(t["garments"].size(), 2u);  // sheet / sheet/i1, sheet / sheet/i2
  ASSERT_EQ(r.figures.size(), 1u);

  // Same numbers on 2 threads, and a recognised entry is used when recognition was right.
  o.threads = 2;
  const Json per_query = Json::array(
      {Json{{"id", "e1"}, {"category_known", {{"both/unweighted", {{"entry", "e0"}, {"correct", true}}}}}}});
  const RegistrationEvalResult r2 = EvaluateRegistration(rel, db, per_query, "test", o);
  for (size_t i = 0; i < 2; ++i) {
    for (const char* k : {"s_to_t_rigid", "t_to_s_rigid", "s_to_t_nonrigid", "t_to_s_nonrigid"}) {
      EXPECT_EQ(r2.table["pairs"][i][k].get<double>(), t["pairs"][i][k].get<double>()) << k;
    }
  }
  EXPECT_EQ(r2.table["pairs"][0]["source_choice"], "recognised");
  EXPECT_EQ(r2.table["pairs"][1]["source_choice"], "first_instance");

  // Limiting pairs per category.
  o.max_pairs_per_category = 1;
  const RegistrationEvalResult r3 = EvaluateRegistration(rel, db, Json(), "test", o);
  EXPECT_EQ(r3.table["pairs"].size(), 1u);
  EXPECT_EQ(r3.table["limited_out"], 1);

  // Figure: a decodable PNG with four panels; markdown has our table and the paper's.
  const std::vector<std::string> names = WriteRegistrationFigures(r, root / "report");
  ASSERT_EQ(names.size(), 1u);
  const cv::Mat img = cv::imread((root / "report" / names[0]).string());
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 4 * 320);
  const std::string md = RegistrationMarkdown(t);
  EXPECT_NE(md.find("S→T (R+N)"), std::string::npos);
  EXPECT_NE(md.find("0.0185"), std::string::npos);
  EXPECT_NE(md.find("**Average**"), std::string::npos);

  EXPECT_THROW(
      {
        RegistrationEvalOptions bad;
        bad.max_pairs_per_category = -1;
        EvaluateRegistration(rel, db, Json(), "test", bad);
      },
      Error);
  if (!std::getenv("DRAPE_KEEP_TEST_OUTPUT")) fs::remove_all(root);
}

}  // namespace
}  // namespace drape::recognition
