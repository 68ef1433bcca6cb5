// Scaling + ICP recover a known similarity transform of a mesh.
#include <gtest/gtest.h>

#include <cstdio>

#include "common/error.h"
#include "runtime/registration/registration.h"
#include "runtime/registration/test_meshes.h"

namespace drape::registration {
namespace {

TEST(Scaling, AreaWeightedFrameOfASphere) {
  const TriMesh s = testing::IcoSphere(4, 0.5);
  const MeshFrame f = AreaWeightedFrame(s);
  EXPECT_LT(f.centre.norm(), 1e-12);
  // Barycentres sit slightly inside the sphere: l → r as the mesh is refined.
  EXPECT_NEAR(f.size, 0.5, 0.002);
  EXPECT_NEAR(f.area, 4 * M_PI * 0.25, 0.02);
  EXPECT_THROW(AreaWeightedFrame(TriMesh{}), Error);
}

TEST(Scaling, FrameIsEquivariantUnderSimilarities) {
  const TriMesh m = testing::FlatTube(30, 20, 0.5, 0.7, 0.05);
  Similarity T;
  T.scale = 1.7;
  T.rotation = Eigen::AngleAxisd(0.4, Vec3(0.2, 1, 0.1).normalized()).toRotationMatrix();
  T.translation = Vec3(0.1, -0.2, 0.3);
  TriMesh n{T.Apply(m.V), m.F};
  const MeshFrame a = AreaWeightedFrame(m), b = AreaWeightedFrame(n);
  EXPECT_NEAR(b.size, 1.7 * a.size, 1e-12);
  EXPECT_LT((b.centre - T.Apply(a.centre)).norm(), 1e-12);
}

// The source is a similarity transform of the target (rotation 20° about a tilted
// axis, scale 0.8, offset): scaling + ICP must map every source vertex back onto its
// original position.
void RecoverSimilarity(const TriMesh& target, double angle, bool refined, double tol_rel) {
  Similarity T;
  T.scale = 0.8;
  T.rotation = Eigen::AngleAxisd(angle, Vec3(0.3, 1, 0.2).normalized()).toRotationMatrix();
  T.translation = Vec3(0.05, -0.1, 0.07);
  const TriMesh source{T.Apply(target.V), target.F};
  RegistrationOptions o;
  o.nonrigid = false;
  o.grid.cells = 64;
  o.icp.max_iterations = 300;
  o.icp.angle_tolerance = o.icp.translation_tolerance = 1e-7;
  o.icp.refined_query = refined;
  const RegistrationResult r = Register(source, target, o);
  const double size = AreaWeightedFrame(target).size;
  const double err = (r.rigid.V - target.V).rowwise().norm().maxCoeff();
  std::printf(
      "similarity recovery (%s query): scale %.6f (want %.6f), max vertex error %.2e m = %.2e·l, ICP %d it, rms %.2e → "
      "%.2e\n",
      refined ? "refined" : "paper 8-point", r.report.scaling.scale, 1 / T.scale, err, err / size,
      r.report.icp.iterations, r.report.icp.rms_before, r.report.icp.rms_after);
  EXPECT_NEAR(r.report.scaling.scale, 1 / T.scale, 1e-9);
  EXPECT_TRUE(r.report.icp.converged);
  EXPECT_LT(err, tol_rel * size);
  // The reported transform is the one applied.
  EXPECT_LT((r.report.rigid.Apply(source.V) - r.rigid.V).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Icp, RecoversSimilarityOfATube) { RecoverSimilarity(testing::FlatTube(40, 30, 0.5, 0.7, 0.06), 0.35, true, 1e-4); }
TEST(Icp, RecoversSimilarityOfAWavySheet) {
  RecoverSimilarity(testing::WavySheet(30, 25, 0.6, 0.5, 0.1), 0.35, true, 1e-4);
}
// The paper's 8-point query quantises the correspondences to the grid: ICP stops within
// a fraction of a cell (h ≈ 0.02 l here).
TEST(Icp, PaperQueryRecoversSimilarityToAFractionOfACell) {
  RecoverSimilarity(testing::FlatTube(40, 30, 0.5, 0.7, 0.06), 0.35, false, 0.03);
}

TEST(Icp, OptionsAreValidated) {
  IcpOptions o;
  o.max_iterations = -1;
  EXPECT_THROW(o.Validate(), Error);
  RegistrationOptions r;
  r.kappa = -1;
  EXPECT_THROW(r.Validate(), Error);
}

}  // namespace
}  // namespace drape::registration
