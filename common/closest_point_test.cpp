#include "common/closest_point.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"
#include "common/rng.h"

namespace drape {
namespace {

// A bumpy, folded sheet: z = 0.1 sin(3x) cos(2y) on a 12×9 grid over [0, 1]², plus a
// copy folded back above it (two layers, as hung garments have).
TriMesh BumpySheet() {
  const int nx = 12, ny = 9;
  TriMesh m;
  m.V.resize(Eigen::Index{2} * (nx + 1) * (ny + 1), 3);
  m.F.resize(Eigen::Index{4} * nx * ny, 3);
  int f = 0;
  for (int layer = 0; layer < 2; ++layer) {
    const int base = layer * (nx + 1) * (ny + 1);
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        const double x = double(i) / nx, y = double(j) / ny;
        m.V.row(base + j * (nx + 1) + i) << x, y, 0.1 * std::sin(3 * x) * std::cos(2 * y) + 0.05 * layer;
      }
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const int a = base + j * (nx + 1) + i, b = a + 1, c = a + nx + 2, d = a + nx + 1;
        m.F.row(f++) << a, b, c;
        m.F.row(f++) << a, c, d;
      }
  }
  return m;
}

TEST(ExactClosestPoint, MatchesBruteForceEverywhere) {
  const TriMesh mesh = BumpySheet();
  const ExactClosestPoint exact(mesh);
  Rng rng(5);
  for (int q = 0; q < 2000; ++q) {
    const double px = rng.Uniform(-0.5, 1.5), py = rng.Uniform(-0.5, 1.5), pz = rng.Uniform(-0.5, 0.6);
    const Vec3 p(px, py, pz);
    const ClosestPoint a = exact.Query(p), b = BruteForceClosestPoint(mesh, p);
    ASSERT_EQ(a.distance, b.distance) << "query " << q;
    EXPECT_EQ(a.triangle, b.triangle) << "query " << q;  // ties go to the lowest index in both
    EXPECT_NEAR((a.point - p).norm(), a.distance, 1e-12);
  }
}

TEST(ExactClosestPoint, PointOnTheMeshIsAtDistanceZero) {
  const TriMesh mesh = BumpySheet();
  const ExactClosestPoint exact(mesh);
  for (int v = 0; v < mesh.NumVertices(); v += 7) EXPECT_EQ(exact.Query(mesh.V.row(v).transpose()).distance, 0.0);
}

// Far from the origin the float BVH and query centre are off by ~1e-6 m: queries a
// micrometre or less from the surface must still find the exact closest triangle.
TEST(ExactClosestPoint, MatchesBruteForceNearTheSurfaceFarFromTheOrigin) {
  TriMesh mesh = BumpySheet();
  mesh.V.rowwise() += Eigen::RowVector3d(20, -15, 30);
  const ExactClosestPoint exact(mesh);
  Rng rng(11);
  for (int q = 0; q < 2000; ++q) {
    const int f = static_cast<int>(rng.Below(mesh.NumFaces()));
    const double s = std::sqrt(rng.Uniform()), t = rng.Uniform();
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    const Vec3 on = (1 - s) * a + s * (1 - t) * b + s * t * c;
    const double dx = rng.Uniform(-1, 1), dy = rng.Uniform(-1, 1), dz = rng.Uniform(-1, 1);
    const Vec3 dir = Vec3(dx, dy, dz).normalized();
    const Vec3 p = on + std::pow(10.0, rng.Uniform(-9, -5)) * dir;
    const ClosestPoint got = exact.Query(p), want = BruteForceClosestPoint(mesh, p);
    ASSERT_EQ(got.distance, want.distance) << "query " << q;
    EXPECT_EQ(got.triangle, want.triangle) << "query " << q;
  }
}

TEST(ExactClosestPoint, EmptyMeshIsAnError) { EXPECT_THROW(ExactClosestPoint(TriMesh{}), Error); }

}  // namespace
}  // namespace drape
