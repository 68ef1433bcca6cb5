#include "common/mesh.h"

#include <gtest/gtest.h>

#include "common/rng.h"

namespace drape {
namespace {

TriMesh Tetrahedron() {
  TriMesh m;
  m.V.resize(4, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  m.F.resize(4, 3);
  m.F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return m;
}

TEST(Mesh, AreasAndNormalsOfTetrahedron) {
  const TriMesh m = Tetrahedron();
  const Eigen::VectorXd a = FaceAreas(m);
  EXPECT_NEAR(a[0], 0.5, 1e-15);
  EXPECT_NEAR(a[3], std::sqrt(3.0) / 2, 1e-15);
  const Points3 n = FaceNormals(m);
  EXPECT_NEAR(n(0, 2), -1.0, 1e-15);  // base faces down (outward)
  EXPECT_NEAR(SurfaceArea(m), 1.5 + std::sqrt(3.0) / 2, 1e-12);
  // Centre of area: Σ a_f g_f / Σ a_f, here by hand (three right triangles of area 1/2
  // with barycentres (1/3,1/3,0), (1/3,0,1/3), (0,1/3,1/3); the slanted one √3/2 at (1/3,1/3,1/3)).
  const double w = std::sqrt(3.0) / 2;
  const double c = (0.5 * (2.0 / 3) + w / 3) / (1.5 + w);
  EXPECT_TRUE(CentreOfArea(m).isApprox(Vec3(c, c, c), 1e-14)) << CentreOfArea(m).transpose();
}

TEST(Mesh, TopologyOfClosedAndOpenMeshes) {
  TriMesh m = Tetrahedron();
  EdgeTopology t = BuildEdgeTopology(m);
  EXPECT_EQ(t.edges.size(), 6u);
  for (const auto& e : t.edges) EXPECT_GE(e.faces[1], 0);
  EXPECT_TRUE(t.nonmanifold.empty());
  EXPECT_EQ(ConnectedComponents(m), 1);

  m.F.conservativeResize(3, 3);  // open it
  t = BuildEdgeTopology(m);
  int boundary = 0;
  for (const auto& e : t.edges) boundary += e.faces[1] < 0;
  EXPECT_EQ(boundary, 3);
}

TEST(Mesh, NonManifoldEdgeIsReported) {
  TriMesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1;
  m.F.resize(3, 3);
  m.F << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  const EdgeTopology t = BuildEdgeTopology(m);
  ASSERT_EQ(t.nonmanifold.size(), 1u);
  EXPECT_EQ(t.nonmanifold[0], (std::array<int, 2>{0, 1}));
}

TEST(Mesh, ClosestPointOnTriangleMatchesDenseSampling) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0.2, 1, 0.3);
  Rng rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const double px = rng.Uniform(-1, 2), py = rng.Uniform(-1, 2), pz = rng.Uniform(-1, 1);
    const Vec3 p(px, py, pz);
    const Vec3 q = ClosestPointOnTriangle(p, a, b, c);
    double best = 1e9;
    const int n = 200;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Vec3 s = a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n);
        best = std::min(best, (s - p).norm());
      }
    EXPECT_LE((q - p).norm(), best + 1e-12);
    EXPECT_NEAR((q - p).norm(), best, 0.01);
  }
}

}  // namespace
}  // namespace drape
