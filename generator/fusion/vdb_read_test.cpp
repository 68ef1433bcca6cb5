#include "generator/fusion/vdb_read.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>

#include "common/error.h"
#include "common/rng.h"
#include "generator/fusion/fusion.h"
#include "generator/fusion/synthetic.h"

namespace drape {
namespace {

namespace fs = std::filesystem;

// A fused sphere written to a .vdb file, read back: the reader must give back the field
// Tsdf::Sdf defines (the brute-force reference).
class VdbRead : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    Intrinsics K;
    K.width = 160, K.height = 120, K.fx = K.fy = 131.25, K.cx = 79.5, K.cy = 59.5;
    synthetic::TurntableOptions t;
    t.frames = 24;
    const synthetic::Scene scene{{synthetic::Shape::Sphere(Vec3(0.02, -0.3, -0.01), 0.1)}};
    FusionOptions o;
    o.voxels_per_metre = 128;
    o.frames_stride = 1;
    fused_ = new FusionResult(FuseFrames(synthetic::RenderTurntable(scene, K, t), K, o, 7));
    path_ = new fs::path(fs::temp_directory_path() / ("drape_vdb_read_" + std::to_string(::getpid()) + ".vdb"));
    std::ofstream(*path_, std::ios::binary) << fused_->tsdf->EncodeVdb();
  }
  static void TearDownTestSuite() {
    fs::remove(*path_);
    delete fused_;
    delete path_;
  }
  static FusionResult* fused_;
  static fs::path* path_;
};
FusionResult* VdbRead::fused_ = nullptr;
fs::path* VdbRead::path_ = nullptr;

TEST_F(VdbRead, SampleEqualsTsdf) {
  const SdfGrid g = SdfGrid::Read(*path_);
  const Tsdf& t = *fused_->tsdf;
  EXPECT_DOUBLE_EQ(g.voxel_size(), 1.0 / 128);
  Rng rng(11);
  for (int i = 0; i < 2000; ++i) {
    const double px = rng.Uniform(-0.2, 0.2), py = rng.Uniform(-0.5, -0.1), pz = rng.Uniform(-0.2, 0.2);
    const Vec3 p(px, py, pz);
    // OpenVDB interpolates in float, Tsdf in double over the same float voxel values.
    EXPECT_NEAR(g.Sample(p), t.Sdf(p), 1e-6) << p.transpose();
  }
}

TEST_F(VdbRead, DenseHoldsEveryVoxel) {
  const DenseSdf d = SdfGrid::Read(*path_).Dense();
  const Tsdf& t = *fused_->tsdf;
  ASSERT_GT(d.dims.minCoeff(), 0);
  EXPECT_NEAR(d.truncation, t.options().Truncation(), 1e-7);
  const Eigen::Matrix4d m = d.IndexToObject();
  int inside = 0;
  size_t i = 0;
  for (int a = 0; a < d.dims.x(); ++a)
    for (int b = 0; b < d.dims.y(); ++b)
      for (int c = 0; c < d.dims.z(); ++c, ++i) {
        const Vec3 p = (m * Eigen::Vector4d(a, b, c, 1)).head<3>();
        ASSERT_FLOAT_EQ(d.sdf[i], float(t.Sdf(p))) << a << " " << b << " " << c;
        EXPECT_FLOAT_EQ(d.weight[i], float(t.Weight(p)));
        inside += d.sdf[i] < 0;
      }
  EXPECT_GT(inside, 1000);  // the sphere's interior, unobserved, reads inside
  // The box covers the surface: every mesh vertex lies inside it.
  const Eigen::Vector3d lo = d.origin.cast<double>() * d.voxel_size;
  const Eigen::Vector3d hi = (d.origin + d.dims).cast<double>() * d.voxel_size;
  for (int v = 0; v < fused_->mesh.NumVertices(); ++v) {
    const Vec3 p = fused_->mesh.V.row(v);
    EXPECT_TRUE((p.array() >= lo.array()).all() && (p.array() <= hi.array()).all());
  }
}

std::vector<std::array<double, 3>> SortedRows(const Points3& P) {
  std::vector<std::array<double, 3>> rows(P.rows());
  for (Eigen::Index i = 0; i < P.rows(); ++i) rows[i] = {P(i, 0), P(i, 1), P(i, 2)};
  std::sort(rows.begin(), rows.end());
  return rows;
}

// Tsdf::SurfacePoints (block by block) against every edge of the dense copy.
TEST_F(VdbRead, SurfacePointsEqualDenseBruteForce) {
  const Points3 fast = fused_->tsdf->SurfacePoints();
  const Points3 brute = DenseSurfacePoints(SdfGrid::Read(*path_).Dense());
  ASSERT_GT(fast.rows(), 1000);
  EXPECT_EQ(SortedRows(fast), SortedRows(brute));
  // Where the mesh is: the same extent to within a voxel.
  const Points3& V = fused_->mesh.V;
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(fast.col(a).maxCoeff(), V.col(a).maxCoeff(), 1.0 / 128) << a;
    EXPECT_NEAR(fast.col(a).minCoeff(), V.col(a).minCoeff(), 1.0 / 128) << a;
  }
}

TEST_F(VdbRead, BadFilesThrow) {
  EXPECT_THROW(SdfGrid::Read("/nonexistent/sdf.vdb"), Error);
  const fs::path bad = fs::temp_directory_path() / ("drape_vdb_bad_" + std::to_string(::getpid()) + ".vdb");
  std::ofstream(bad, std::ios::binary) << "not a vdb file at all";
  try {
    SdfGrid::Read(bad);
    ADD_FAILURE() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos) << e.what();
  }
  fs::remove(bad);
}

}  // namespace
}  // namespace drape
