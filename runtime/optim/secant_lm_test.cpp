// The secant Levenberg–Marquardt on analytic problems: with analytic Jacobians
// (registration's use) and with forward differences only (folding's use: one scalar
// cost C(x), minimised as C², δ = 0.1 as in the paper).
#include "runtime/optim/secant_lm.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "common/error.h"

namespace drape::optim {
namespace {

// A tiny least-squares problem (Rosenbrock as residuals) for the solver itself.
class Rosenbrock : public LeastSquaresProblem {
 public:
  int NumResiduals() const override { return 2; }
  int NumParameters() const override { return 2; }
  void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override {
    r.resize(2);
    r << 10 * (x[1] - x[0] * x[0]), 1 - x[0];
  }
  void Jacobian(const Eigen::VectorXd& x, Eigen::SparseMatrix<double, Eigen::RowMajor>& J) const override {
    J.resize(2, 2);
    std::vector<Eigen::Triplet<double>> t = {{0, 0, -20 * x[0]}, {0, 1, 10}, {1, 0, -1}, {1, 1, 0}};
    J.setFromTriplets(t.begin(), t.end());
  }
};

TEST(SecantLm, SolvesRosenbrockWithAndWithoutSecantUpdates) {
  for (bool secant : {true, false}) {
    Eigen::VectorXd x(2);
    x << -1.2, 1;
    SecantLmOptions o;
    o.secant = secant;
    o.max_iterations = 200;
    o.relative_decrease = 0;
    o.tau = 1e-3;
    const SecantLmReport rep = SolveSecantLm(Rosenbrock(), x, o);
    EXPECT_NEAR(x[0], 1, 1e-6) << (secant ? "secant" : "plain") << " " << rep.termination;
    EXPECT_NEAR(x[1], 1, 1e-6);
    EXPECT_LT(rep.final_cost, 1e-12);
    if (secant) {
      EXPECT_GT(rep.secant_updates, 0);
    }
    std::printf("Rosenbrock %s: %d iterations, %d fresh Jacobians, %d secant updates, %s\n",
                secant ? "secant" : "plain", rep.iterations, rep.fresh_jacobians, rep.secant_updates,
                rep.termination.c_str());
  }
}

TEST(SecantLm, ValidatesOptions) {
  SecantLmOptions o;
  o.refresh_every = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.tau = 0;
  EXPECT_THROW(o.Validate(), Error);
}

// Rosenbrock without its Jacobian: Madsen's Alg. 3.34 from forward differences alone.
class RosenbrockNoJacobian : public LeastSquaresProblem {
 public:
  int NumResiduals() const override { return 2; }
  int NumParameters() const override { return 2; }
  void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override { Rosenbrock().Residuals(x, r); }
};

TEST(SecantLm, SolvesRosenbrockFromFiniteDifferences) {
  Eigen::VectorXd x(2);
  x << -1.2, 1;
  SecantLmOptions o;
  o.finite_difference_step = 1e-7;
  o.max_iterations = 400;
  o.relative_decrease = 0;
  o.tau = 1e-3;
  const SecantLmReport rep = SolveSecantLm(RosenbrockNoJacobian(), x, o);
  EXPECT_NEAR(x[0], 1, 1e-4) << rep.termination;
  EXPECT_NEAR(x[1], 1, 1e-4);
  EXPECT_EQ(rep.fresh_jacobians, 1);  // B0 only; then secant + coordinate refreshes
  EXPECT_GT(rep.secant_updates, rep.accepted);
  std::printf("Rosenbrock finite differences: %d iterations, %d residual evaluations, %s\n", rep.iterations,
              rep.residual_evaluations, rep.termination.c_str());
}

TEST(SecantLm, NoJacobianWithoutFiniteDifferencesIsAnError) {
  Eigen::VectorXd x(2);
  x << -1.2, 1;
  EXPECT_THROW(SolveSecantLm(RosenbrockNoJacobian(), x, SecantLmOptions{}), Error);
}

// The folding use: one residual r = C(x) > 0, a smooth bowl in six parameters (two
// control points) with minimum C* = 0.5 at a, minimised as ½C² with δ = 0.1.
class Bowl : public LeastSquaresProblem {
 public:
  Bowl() {
    a_.resize(6);
    a_ << 0.1, 0.3, -0.2, 0.4, 0.25, 0.05;
    w_.resize(6);
    w_ << 1, 2, 0.5, 1, 3, 1.5;
  }
  int NumResiduals() const override { return 1; }
  int NumParameters() const override { return 6; }
  void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override {
    r.resize(1);
    r[0] = 0.5 + (w_.array() * (x - a_).array().square()).sum();
    ++calls;
  }
  const Eigen::VectorXd& a() const { return a_; }
  mutable int calls = 0;

 private:
  Eigen::VectorXd a_, w_;
};

TEST(SecantLm, MinimisesAScalarCostSquaredWithThePapersDelta) {
  Bowl bowl;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  x[1] = 1.0;
  SecantLmOptions o;
  o.finite_difference_step = 0.1;
  o.max_iterations = 100;
  o.step_tolerance = 1e-4;
  const SecantLmReport rep = SolveSecantLm(bowl, x, o);
  // C(x0) = 0.5 + 1.36125; the minimum is 0.5. Forward differences with δ = 0.1 bias
  // each gradient component by w_j·δ (a stationary point δ/2 off in every coordinate,
  // C = 0.5225); the secant updates along short steps mix in unbiased slopes, so x lands
  // within δ of a and C below that biased value.
  EXPECT_NEAR(std::sqrt(2 * rep.initial_cost), 1.86125, 1e-12);
  EXPECT_LT(std::sqrt(2 * rep.final_cost), 0.5225) << rep.termination;
  EXPECT_LT((x - bowl.a()).lpNorm<Eigen::Infinity>(), 0.1);
  EXPECT_EQ(rep.residual_evaluations, bowl.calls);
  EXPECT_EQ(rep.fresh_jacobians, 1);
  std::printf("bowl: C %.4f -> %.4f in %d iterations, %d evaluations, %s\n", std::sqrt(2 * rep.initial_cost),
              std::sqrt(2 * rep.final_cost), rep.iterations, rep.residual_evaluations, rep.termination.c_str());
}

TEST(SecantLm, StopsAtTheEvaluationBudget) {
  Bowl bowl;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  SecantLmOptions o;
  o.finite_difference_step = 0.1;
  o.max_residual_evaluations = 12;  // 1 + 6 for B0 leave room for two or three iterations
  const SecantLmReport rep = SolveSecantLm(bowl, x, o);
  EXPECT_EQ(rep.termination, "max_residual_evaluations");
  EXPECT_LE(rep.residual_evaluations, 12);
  EXPECT_LT(rep.final_cost, rep.initial_cost);
}

// max_step: no step longer than the cap, and still to the bowl's minimum. From far away
// the uncapped Gauss-Newton step of the single residual aims at C = 0 and overshoots.
TEST(SecantLm, MaxStepCapsEveryStep) {
  struct Recorder : Bowl {
    void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override {
      Bowl::Residuals(x, r);
      xs.push_back(x);
    }
    mutable std::vector<Eigen::VectorXd> xs;
  } bowl;
  Eigen::VectorXd x = Eigen::VectorXd::Constant(6, 2.0);
  SecantLmOptions o;
  o.finite_difference_step = 0.1;
  o.max_iterations = 200;
  o.step_tolerance = 1e-4;
  o.max_step = 0.25;
  const SecantLmReport rep = SolveSecantLm(bowl, x, o);
  EXPECT_GT(rep.shortened, 0);
  // Evaluations: x0, then x0 + δe_j (B0), then steps from accepted points and
  // coordinate probes (δ): every evaluated point is within max_step or δ of an earlier one.
  for (size_t i = 1; i < bowl.xs.size(); ++i) {
    double nearest = HUGE_VAL;
    for (size_t j = 0; j < i; ++j) nearest = std::min(nearest, (bowl.xs[i] - bowl.xs[j]).norm());
    EXPECT_LE(nearest, o.max_step + 1e-12) << "evaluation " << i;
  }
  EXPECT_LT(std::sqrt(2 * rep.final_cost), 0.5225) << rep.termination;
  EXPECT_LT((x - bowl.a()).lpNorm<Eigen::Infinity>(), 0.1);
  o.max_step = -1;
  EXPECT_THROW(o.Validate(), Error);
}

}  // namespace
}  // namespace drape::optim
