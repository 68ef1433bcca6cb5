// The paper's discretised dissimilarity D̃: zero for identical meshes, the translation
// distance for a translated mesh, a hand-computed value for one moved triangle, and the
// cost C = l + αD.
#include "runtime/folding/dissimilarity.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace drape::folding {
namespace {

// A 2 × 1 grid of unit squares split into four triangles, z = 0.
TriMesh Strip() {
  TriMesh m;
  m.V.resize(6, 3);
  m.V << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 1, 1, 0, 2, 1, 0;
  m.F.resize(4, 3);
  m.F << 0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4;
  return m;
}

TEST(Dissimilarity, ZeroForIdenticalMeshes) { EXPECT_EQ(Dissimilarity(Strip(), Strip()), 0.0); }

TEST(Dissimilarity, TranslatedMeshGivesTheTranslationDistance) {
  TriMesh moved = Strip();
  const Vec3 t(0.03, -0.04, 0.12);  // |t| = 0.13
  moved.V.rowwise() += t.transpose();
  EXPECT_NEAR(Dissimilarity(Strip(), moved), 0.13, 1e-15);
}

TEST(Dissimilarity, WeightsEachTriangleByItsTargetArea) {
  // Lift vertex 2 (only in triangle 2, area ½ of a total 2) by 0.3: that barycentre
  // rises by 0.1, so D = 0.1 · ½ / 2 = 0.025.
  TriMesh sim = Strip();
  sim.V(2, 2) = 0.3;
  EXPECT_NEAR(Dissimilarity(Strip(), sim), 0.025, 1e-15);
  // The target's areas weigh, not the simulated ones: swapping the roles changes A_i.
  EXPECT_GT(Dissimilarity(sim, Strip()), 0.0);
}

TEST(Dissimilarity, RejectsDifferentTriangulations) {
  TriMesh other = Strip();
  other.F.row(0) << 0, 4, 1;
  EXPECT_THROW(Dissimilarity(Strip(), other), Error);
  TriMesh flat = Strip();
  flat.V.col(1).setZero();
  flat.V.col(0).setZero();
  EXPECT_THROW(Dissimilarity(flat, flat), Error);
}

TEST(Dissimilarity, CostIsLengthPlusAlphaTimesD) {
  EXPECT_DOUBLE_EQ(FoldCost(0.5, 0.002), 0.5 + 2.0);
  EXPECT_DOUBLE_EQ(FoldCost(0.5, 0.002, 10), 0.52);
}

}  // namespace
}  // namespace drape::folding
