#include "runtime/optim/secant_lm.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/error.h"

namespace drape::optim {

namespace {
using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Schubert's sparse Broyden update: row i gets (y_i − B_i h) s_iᵀ / s_iᵀs_i with s_i
// the step restricted to row i's pattern.
void SchubertUpdate(Eigen::SparseMatrix<double, Eigen::RowMajor>& B, const Eigen::VectorXd& h,
                    const Eigen::VectorXd& y) {
  const int* outer = B.outerIndexPtr();
  const int* inner = B.innerIndexPtr();
  double* val = B.valuePtr();
  for (int i = 0; i < B.rows(); ++i) {
    double bh = 0, ss = 0;
    for (int p = outer[i]; p < outer[i + 1]; ++p) {
      bh += val[p] * h[inner[p]];
      ss += h[inner[p]] * h[inner[p]];
    }
    if (ss <= 1e-300) continue;
    const double c = (y[i] - bh) / ss;
    for (int p = outer[i]; p < outer[i + 1]; ++p) val[p] += c * h[inner[p]];
  }
}
// Forward-difference Jacobian with a dense pattern: column j = (r(x + δe_j) − r0)/δ.
template <class Eval>
void DifferenceJacobian(const Eval& eval, const Eigen::VectorXd& x, const Eigen::VectorXd& r0, double delta,
                        Eigen::SparseMatrix<double, Eigen::RowMajor>& B) {
  const int m = static_cast<int>(r0.size()), n = static_cast<int>(x.size());
  Eigen::MatrixXd D(m, n);
  Eigen::VectorXd xj = x, rj;
  for (int j = 0; j < n; ++j) {
    xj[j] = x[j] + delta;
    eval(xj, rj);
    xj[j] = x[j];
    D.col(j) = rj.allFinite() ? Eigen::VectorXd((rj - r0) / delta) : Eigen::VectorXd::Zero(m);
  }
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<size_t>(m) * n);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) t.emplace_back(i, j, D(i, j));
  B.resize(m, n);
  B.setFromTriplets(t.begin(), t.end());
}
}  // namespace

void LeastSquaresProblem::Jacobian(const Eigen::VectorXd&, Eigen::SparseMatrix<double, Eigen::RowMajor>&) const {
  throw Error("secant LM: the problem has no analytic Jacobian; set SecantLmOptions.finite_difference_step > 0");
}

void SecantLmOptions::Validate() const {
  if (max_iterations < 0) throw Error("SecantLmOptions.max_iterations must be >= 0");
  if (refresh_every < 1) throw Error("SecantLmOptions.refresh_every must be >= 1");
  if (!(tau > 0)) throw Error("SecantLmOptions.tau must be > 0");
  if (!(gradient_tolerance >= 0)) throw Error("SecantLmOptions.gradient_tolerance must be >= 0");
  if (!(step_tolerance >= 0)) throw Error("SecantLmOptions.step_tolerance must be >= 0");
  if (!(relative_decrease >= 0 && relative_decrease < 1)) throw Error("SecantLmOptions.relative_decrease must be in [0, 1)");
  if (stall_iterations < 1) throw Error("SecantLmOptions.stall_iterations must be >= 1");
  if (!(finite_difference_step >= 0 && std::isfinite(finite_difference_step)))
    throw Error("SecantLmOptions.finite_difference_step must be >= 0 and finite");
  if (max_residual_evaluations < 0) throw Error("SecantLmOptions.max_residual_evaluations must be >= 0");
}

SecantLmReport SolveSecantLm(const LeastSquaresProblem& problem, Eigen::VectorXd& x, const SecantLmOptions& options) {
  options.Validate();
  const int n = problem.NumParameters();
  DRAPE_CHECK(x.size() == n, "parameter vector size");
  SecantLmReport rep;
  Eigen::SparseMatrix<double, Eigen::RowMajor> B;
  Eigen::VectorXd r, r_new, x_new, h, g;

  const bool numeric = options.finite_difference_step > 0;
  const double delta = options.finite_difference_step;
  auto eval = [&](const Eigen::VectorXd& at, Eigen::VectorXd& out) {
    problem.Residuals(at, out);
    ++rep.residual_evaluations;
  };
  auto t0 = Clock::now();
  eval(x, r);
  rep.residual_seconds += Since(t0);
  if (!r.allFinite()) throw NumericalError("secant LM: non-finite initial residuals");
  auto fresh = [&]() {
    const auto t = Clock::now();
    if (numeric)
      DifferenceJacobian(eval, x, r, delta, B);
    else
      problem.Jacobian(x, B);
    rep.jacobian_seconds += Since(t);
    ++rep.fresh_jacobians;
  };
  fresh();
  int updates_since_fresh = 0;
  double F = 0.5 * r.squaredNorm();
  rep.initial_cost = F;
  g = B.transpose() * r;

  Eigen::SparseMatrix<double> I(n, n);
  I.setIdentity();
  Eigen::SparseMatrix<double> BtB = Eigen::SparseMatrix<double>(B.transpose()) * B;
  double mu = options.tau * std::max(BtB.diagonal().maxCoeff(), 1e-300);
  double nu = 2;
  bool btb_valid = true;
  int stall = 0;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  bool analysed = false;
  rep.termination = "max_iterations";
  int coordinate = -1;  // Madsen's j (numeric mode)
  Eigen::VectorXd x_j, r_j;

  for (int k = 0; k < options.max_iterations; ++k) {
    if (g.lpNorm<Eigen::Infinity>() <= options.gradient_tolerance) {
      rep.termination = "gradient";
      break;
    }
    // An iteration costs one evaluation, two with a coordinate refresh.
    if (options.max_residual_evaluations > 0 &&
        rep.residual_evaluations + (numeric ? 2 : 1) > options.max_residual_evaluations) {
      rep.termination = "max_residual_evaluations";
      break;
    }
    t0 = Clock::now();
    if (!btb_valid) BtB = Eigen::SparseMatrix<double>(B.transpose()) * B;
    btb_valid = true;
    const Eigen::SparseMatrix<double> A = BtB + mu * I;
    auto tp = Clock::now();
    rep.product_seconds += Since(t0);
    // B keeps one pattern, so the ordering is computed once.
    if (!analysed) ldlt.analyzePattern(A), analysed = true;
    ldlt.factorize(A);
    rep.factor_seconds += Since(tp);
    if (ldlt.info() != Eigen::Success) throw NumericalError("secant LM: factorisation failed");
    h = ldlt.solve(-g);
    rep.solve_seconds += Since(t0);
    if (!h.allFinite()) throw NumericalError("secant LM: non-finite step");
    rep.iterations = k + 1;
    if (h.norm() <= options.step_tolerance * (x.norm() + options.step_tolerance)) {
      rep.termination = "step";
      rep.cost.push_back(F);
      break;
    }
    if (numeric && options.secant) {
      // Keep B good along every coordinate: refresh column j unless h already probes it.
      coordinate = (coordinate + 1) % n;
      if (std::abs(h[coordinate]) < 0.8 * h.norm()) {
        x_j = x;
        x_j[coordinate] += delta;
        t0 = Clock::now();
        eval(x_j, r_j);
        rep.residual_seconds += Since(t0);
        if (r_j.allFinite()) {
          SchubertUpdate(B, x_j - x, r_j - r);
          ++rep.secant_updates;
          btb_valid = false;
        }
      }
    }
    x_new = x + h;
    t0 = Clock::now();
    eval(x_new, r_new);
    rep.residual_seconds += Since(t0);
    const double F_new = r_new.allFinite() ? 0.5 * r_new.squaredNorm() : HUGE_VAL;
    // Predicted decrease L(0) − L(h) = ½ hᵀ(μh − g).
    const double predicted = 0.5 * h.dot(mu * h - g);
    const double rho = predicted > 0 ? (F - F_new) / predicted : -1;
    // The secant information along h is valid whether or not the step is taken.
    const bool use_secant = options.secant && r_new.allFinite();
    if (use_secant) {
      SchubertUpdate(B, h, r_new - r);
      ++rep.secant_updates;
      ++updates_since_fresh;
      btb_valid = false;
    }
    if (rho > 0) {
      const double decrease = (F - F_new) / std::max(F, 1e-300);
      x = x_new;
      r = r_new;
      F = F_new;
      ++rep.accepted;
      mu *= std::max(1.0 / 3, 1 - std::pow(2 * rho - 1, 3));
      nu = 2;
      stall = decrease < options.relative_decrease ? stall + 1 : 0;
    } else {
      ++rep.rejected;
      mu *= nu;
      nu *= 2;
    }
    rep.cost.push_back(F);
    if (stall >= options.stall_iterations) {
      rep.termination = "relative_decrease";
      break;
    }
    const bool stale = updates_since_fresh > 0;
    // Numeric secant mode never refreshes in full (n evaluations): the coordinate
    // refresh keeps B current instead.
    const bool refresh = options.secant ? (!numeric && (updates_since_fresh >= options.refresh_every || (rho <= 0 && stale)))
                                         : rho > 0;
    if (refresh) {
      fresh();
      updates_since_fresh = 0;
      btb_valid = false;
    }
    g = B.transpose() * r;
  }
  rep.final_cost = F;
  rep.final_mu = mu;
  return rep;
}

}  // namespace drape::optim
