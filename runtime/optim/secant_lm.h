// Secant Levenberg–Marquardt for sparse nonlinear least squares (Madsen, Nielsen &
// Tingleff 2004, "Methods for non-linear least squares problems", §3.5, Alg. 3.17),
// minimising F(x) = ½‖r(x)‖².
//
// Per iteration: solve (BᵀB + μI) h = −Bᵀr with a sparse LDLᵀ (Eigen SimplicialLDLT);
// evaluate r(x+h); update the Jacobian approximation B by Broyden's rank-one secant
// formula B ← B + (r(x+h) − r(x) − B h) hᵀ / hᵀh — here in Schubert's sparse form
// (each row i uses h restricted to row i's sparsity pattern, so B keeps J's pattern and
// still satisfies the secant equation B h = r(x+h) − r(x) row by row); accept the step
// if the gain ratio ϱ > 0 and update μ as Madsen's Alg. 3.17 (μ ← μ·max(⅓, 1−(2ϱ−1)³),
// ν = 2; else μ ← μν, ν ← 2ν). Madsen refreshes B along one coordinate direction per
// iteration by a finite difference; with analytic Jacobians at hand we instead take a
// fresh analytic Jacobian every `refresh_every` iterations and whenever a step fails
// on a Jacobian that has been secant-updated.
//
// Without an analytic Jacobian (options.finite_difference_step = δ > 0) this is Madsen's
// Alg. 3.34 as written: B0 by forward differences (x + δe_j, one residual evaluation per
// parameter), then per iteration the Broyden update along the step plus, for the next
// coordinate j in turn, a fresh difference column when |h_j| < 0.8‖h‖ (so B stays good
// in every direction); no full refresh afterwards. Meant for small dense problems whose
// residuals are expensive (a cloth simulation per evaluation: trajectory optimisation
// for folding, δ = 0.1 as in the paper).
//
// Shared by registration (analytic, sparse) and folding (finite differences).
#pragma once

#include <Eigen/Sparse>
#include <string>
#include <vector>

namespace drape::optim {

class LeastSquaresProblem {
 public:
  virtual ~LeastSquaresProblem() = default;
  virtual int NumResiduals() const = 0;
  virtual int NumParameters() const = 0;
  virtual void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const = 0;
  // Must return the same sparsity pattern for every x. Problems without one solve with
  // SecantLmOptions::finite_difference_step > 0 and need not override this (the default
  // throws).
  virtual void Jacobian(const Eigen::VectorXd& x, Eigen::SparseMatrix<double, Eigen::RowMajor>& J) const;
};

struct SecantLmOptions {
  int max_iterations = 60;
  bool secant = true;                 // false: a fresh Jacobian every iteration (plain LM)
  int refresh_every = 5;              // fresh Jacobian after this many secant updates
  double tau = 1e-4;                  // μ0 = τ · max diag(JᵀJ)
  double gradient_tolerance = 1e-14;  // stop when ‖Bᵀr‖∞ ≤ this
  double step_tolerance = 1e-9;       // stop when ‖h‖ ≤ this·(‖x‖ + this)
  double relative_decrease = 1e-4;    // ... or when `stall_iterations` accepted steps in a
  int stall_iterations = 3;           //     row each decrease F by less than this fraction
  // > 0: no analytic Jacobian; forward differences with this step (in x's units) and
  // Madsen's coordinate refresh, as described above (refresh_every is then unused).
  double finite_difference_step = 0;
  // > 0: a trust radius on the secant model, in x's units: a longer step is shortened
  // to it along its direction; after a rejected step the radius is half that step's
  // length, after an accepted one max_step again. Folding's single residual C > 0
  // cannot reach 0, yet the Gauss-Newton step of one residual aims at C = 0: its length
  // C/‖∇C‖ extrapolates a model fitted over δ far beyond δ, and μ (which for one
  // residual only rescales the step along −∇C) grows too slowly to fix that within a
  // budget of simulations. 0 = no cap (registration).
  double max_step = 0;
  // > 0: stop before an iteration that could exceed this many residual evaluations
  // (the initial one and the difference columns included); 0 = no cap.
  int max_residual_evaluations = 0;
  void Validate() const;
};

struct SecantLmReport {
  int iterations = 0;
  int accepted = 0, rejected = 0;
  int shortened = 0;  // steps cut to max_step
  int fresh_jacobians = 0, secant_updates = 0;
  double initial_cost = 0, final_cost = 0;  // ½‖r‖²
  double final_mu = 0;
  std::string termination;
  int residual_evaluations = 0;  // calls of Residuals (initial, steps, difference columns)
  std::vector<double> cost;      // after every iteration
  double jacobian_seconds = 0, solve_seconds = 0, residual_seconds = 0;  // timing only
  double product_seconds = 0, factor_seconds = 0;                        // parts of solve_seconds
};

// Minimises from x (updated in place). Throws drape::NumericalError if the residuals
// become non-finite or the linear solve fails.
SecantLmReport SolveSecantLm(const LeastSquaresProblem& problem, Eigen::VectorXd& x, const SecantLmOptions& options);

}  // namespace drape::optim
