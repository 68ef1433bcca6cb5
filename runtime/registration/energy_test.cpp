// The non-rigid energy: analytic Jacobians vs central finite differences, every term
// zero at the rest shape (the secant LM itself is tested in runtime/optim).
#include "runtime/registration/energy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "common/closest_point.h"
#include "common/error.h"
#include "common/rng.h"
#include "runtime/registration/test_meshes.h"

namespace drape::registration {
namespace {

Eigen::VectorXd Perturb(const Eigen::VectorXd& x, double sigma, uint64_t seed) {
  Rng rng(DeriveSeed(seed, "perturb"));
  Eigen::VectorXd y = x;
  for (int i = 0; i < y.size(); ++i) y[i] += rng.Normal(0, sigma);
  return y;
}

// Max |J_analytic − J_fd| over the rows [begin, end), relative to the block's max |J|.
double JacobianError(const RegistrationEnergy& e, const Eigen::VectorXd& x, int begin, int end) {
  SparseRowMatrix J;
  e.Jacobian(x, J);
  const Eigen::MatrixXd Ja = Eigen::MatrixXd(J).middleRows(begin, end - begin);
  Eigen::MatrixXd Jf(end - begin, x.size());
  const double eps = 1e-7;
  Eigen::VectorXd rp, rm;
  for (int c = 0; c < x.size(); ++c) {
    Eigen::VectorXd xp = x, xm = x;
    xp[c] += eps;
    xm[c] -= eps;
    e.Residuals(xp, rp);
    e.Residuals(xm, rm);
    Jf.col(c) = (rp - rm).segment(begin, end - begin) / (2 * eps);
  }
  const double scale = std::max(Ja.cwiseAbs().maxCoeff(), 1e-12);
  return (Ja - Jf).cwiseAbs().maxCoeff() / scale;
}

class EnergyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    rest_ = testing::WavySheet(6, 5, 0.3, 0.25, 0.05);
    // Target: a sphere the sheet is near, so every barycentre has a well-defined,
    // smooth distance (exact closest points via Embree).
    TriMesh sphere = testing::IcoSphere(3, 0.4);
    sphere.V.rowwise() -= Eigen::RowVector3d(0.15, 0.1, -0.5);
    target_ = std::make_unique<ExactClosestPoint>(sphere);
    fn_ = [this](const Vec3& p) { return target_->Query(p); };
  }
  TriMesh rest_;
  std::unique_ptr<ExactClosestPoint> target_;
  ClosestPointFn fn_;
};

TEST_F(EnergyTest, EachTermIsZeroAtRest) {
  const RegistrationEnergy e(rest_, fn_, EnergyWeights{2.0, 3.0, 5.0});
  const Eigen::VectorXd x = RegistrationEnergy::Flatten(rest_.V);
  const EnergyTerms t = e.Terms(x);
  EXPECT_LT(t.area, 1e-24);
  EXPECT_LT(t.angle, 1e-24);
  EXPECT_LT(t.hinge, 1e-24);
  EXPECT_GT(t.fit, 0);  // the target is elsewhere
  // ... and stay zero under a rigid motion (the deformation terms are intrinsic).
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  Points3 moved = rest_.V;
  for (int i = 0; i < moved.rows(); ++i) moved.row(i) = (R * Vec3(rest_.V.row(i)) + Vec3(0.3, -1, 2)).transpose();
  const EnergyTerms m = e.Terms(RegistrationEnergy::Flatten(moved));
  EXPECT_LT(m.area, 1e-20);
  EXPECT_LT(m.angle, 1e-20);
  EXPECT_LT(m.hinge, 1e-20);
  // A deformation makes each of them positive.
  const EnergyTerms d = e.Terms(Perturb(x, 0.01, 1));
  EXPECT_GT(d.area, 1e-8);
  EXPECT_GT(d.angle, 1e-8);
  EXPECT_GT(d.hinge, 1e-8);
}

TEST_F(EnergyTest, JacobianMatchesFiniteDifferencesPerTerm) {
  const RegistrationEnergy e(rest_, fn_, EnergyWeights{2.0, 3.0, 5.0});
  const Eigen::VectorXd x = Perturb(RegistrationEnergy::Flatten(rest_.V), 0.01, 2);
  const int nf = rest_.NumFaces();
  const double fit = JacobianError(e, x, e.fit_begin(), e.area_begin());
  const double area = JacobianError(e, x, e.area_begin(), e.angle_begin());
  const double angle = JacobianError(e, x, e.angle_begin(), e.hinge_begin());
  const double hinge = JacobianError(e, x, e.hinge_begin(), e.NumResiduals());
  std::printf("relative Jacobian error vs FD: fit %.1e area %.1e angle %.1e hinge %.1e (%d faces, %d hinges)\n", fit,
              area, angle, hinge, nf, e.NumHinges());
  EXPECT_LT(fit, 1e-6);
  EXPECT_LT(area, 1e-6);
  EXPECT_LT(angle, 1e-6);
  EXPECT_LT(hinge, 1e-6);
}

TEST(EnergyPrimitives, HingeAngleSignAndGradient) {
  // Flat hinge: zero; folding the wing x2 along +n_A gives a negative angle.
  const Vec3 x0(0, 0, 0), x1(1, 0, 0), x2(0.4, 1, 0), x3(0.7, -0.8, 0);
  EXPECT_NEAR(HingeAngle(x0, x1, x2, x3, nullptr), 0, 1e-15);
  EXPECT_LT(HingeAngle(x0, x1, x2 + Vec3(0, 0, 0.1), x3, nullptr), 0);
  // Strongly folded configuration (past 90°): gradient vs FD.
  const Vec3 y3(0.3, -0.2, 0.9);
  Eigen::Matrix<double, 12, 1> g;
  const double th = HingeAngle(x0, x1, x2, y3, &g);
  EXPECT_GT(std::abs(th), 0.5);
  Vec3 p[4] = {x0, x1, x2, y3};
  for (int v = 0; v < 4; ++v)
    for (int d = 0; d < 3; ++d) {
      Vec3 q[4] = {p[0], p[1], p[2], p[3]}, r[4] = {p[0], p[1], p[2], p[3]};
      q[v][d] += 1e-7;
      r[v][d] -= 1e-7;
      const double fd =
          (HingeAngle(q[0], q[1], q[2], q[3], nullptr) - HingeAngle(r[0], r[1], r[2], r[3], nullptr)) / 2e-7;
      EXPECT_NEAR(g[3 * v + d], fd, 1e-6) << "vertex " << v << " coord " << d;
    }
}

}  // namespace
}  // namespace drape::registration
