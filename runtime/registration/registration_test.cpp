// End-to-end: non-rigid registration of a mesh to a known smooth deformation of itself,
// the error metric against brute force, anchor transfer.
#include "runtime/registration/registration.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "common/error.h"
#include "runtime/registration/test_meshes.h"

namespace drape::registration {
namespace {

struct Case {
  const char* name;
  TriMesh source;
  TriMesh target;
};

void PrintEval(const char* name, const RegistrationEvaluation& ev) {
  const RegistrationReport& r = ev.report;
  std::printf(
      "%s: S→T R %.5f R+N %.5f | T→S R %.5f R+N %.5f | E_fit %.3e → %.3e, area %.2e angle %.2e hinge %.2e | "
      "LM %d it (%d acc, %d rej, %d fresh, %d secant) %s | %.2f s (grid %.2f icp %.2f nonrigid %.2f)\n",
      name, ev.s_to_t_rigid.mean, ev.s_to_t_nonrigid.mean, ev.t_to_s_rigid.mean, ev.t_to_s_nonrigid.mean,
      r.energy_before.fit, r.energy_after.fit, r.energy_after.area, r.energy_after.angle, r.energy_after.hinge,
      r.lm.iterations, r.lm.accepted, r.lm.rejected, r.lm.fresh_jacobians, r.lm.secant_updates,
      r.lm.termination.c_str(), ev.seconds, r.grid_seconds, r.icp_seconds, r.nonrigid_seconds);
  std::printf(
      "  grid %dx%dx%d band %.2f s sweep %.2f s (%d passes); LM jacobian %.2f s solve %.2f s (product %.2f factor "
      "%.2f) residual %.2f s\n",
      r.grid.nx, r.grid.ny, r.grid.nz, r.grid.band_seconds, r.grid.sweep_seconds, r.grid.passes, r.lm.jacobian_seconds,
      r.lm.solve_seconds, r.lm.product_seconds, r.lm.factor_seconds, r.lm.residual_seconds);
}

TEST(Registration, SmoothDeformationOfItself) {
  const TriMesh tube = testing::FlatTube(32, 24, 0.5, 0.7, 0.08);
  const TriMesh target{testing::SmoothDeform(tube.V, 0.03, 6.0), tube.F};
  RegistrationOptions o;
  o.grid.cells = 64;
  const RegistrationEvaluation ev = RegisterAndEvaluate(tube, target, {}, o);
  PrintEval("tube → smooth deformation", ev);
  const RegistrationReport& r = ev.report;
  EXPECT_LT(r.energy_after.fit, r.energy_before.fit / 20);
  EXPECT_LT(ev.s_to_t_nonrigid.mean, ev.s_to_t_rigid.mean / 3);
  EXPECT_LT(ev.t_to_s_nonrigid.mean, ev.t_to_s_rigid.mean);
}

TEST(SymmetricFit, ZeroOnItselfAndTheMeanOfBothDirections) {
  const TriMesh sheet = testing::WavySheet(12, 10, 0.5, 0.4, 0.0);  // flat, z = 0
  const ExactClosestPoint onto(sheet);
  EXPECT_NEAR(SymmetricFit(sheet, sheet, onto), 0.0, 1e-12);
  // The same sheet 2 cm off: 2 cm both ways.
  TriMesh off = sheet;
  off.V.col(2).array() += 0.02;
  EXPECT_NEAR(SymmetricFit(off, sheet, onto), 0.02, 1e-9);
}

TEST(MeasureDirectedNear, ThePatchesWithinTheBallAndTheirAreaWeightedMean) {
  // A flat sheet (z = 0) onto itself lifted by 1 cm on the left half and 2 cm on the right.
  const TriMesh from = testing::WavySheet(11, 9, 1.0, 0.8, 0.0);
  TriMesh to = from;
  for (int v = 0; v < to.NumVertices(); ++v) to.V(v, 2) = to.V(v, 0) > 0.5 ? 0.02 : 0.01;
  const ExactClosestPoint onto(to);
  // Within 15 cm of the left edge's middle: every patch is 1 cm under the left half.
  const DirectedDistance left = MeasureDirectedNear(from, onto, Vec3(0.0, 0.4, 0.0), 0.15);
  EXPECT_GT(left.samples, 0);
  EXPECT_LT(left.samples, from.NumFaces() / 10);
  EXPECT_NEAR(left.mean, 0.01, 1e-12);
  EXPECT_NEAR(left.max, 0.01, 1e-12);
  // A ball holding every patch gives the whole mesh's figures.
  const DirectedDistance all = MeasureDirected(from, onto);
  const DirectedDistance ball = MeasureDirectedNear(from, onto, Vec3(0.5, 0.4, 0.0), 10.0);
  EXPECT_EQ(ball.samples, all.samples);
  EXPECT_NEAR(ball.mean, all.mean, 1e-12);
  // None within: no samples, and a negative radius is an error.
  EXPECT_EQ(MeasureDirectedNear(from, onto, Vec3(9, 9, 9), 0.1).samples, 0);
  EXPECT_THROW(MeasureDirectedNear(from, onto, Vec3::Zero(), -1.0), Error);
}

}  // namespace
}  // namespace drape::registration
