#include "runtime/optim/secant_lm.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/field_error.h"
#include "common/timing.h"

namespace drape::optim {

namespace {

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
  if (max_iterations < 0) BadField(max_iterations, "max_iterations", "must be >= 0");
  if (refresh_every < 1) throw Error("SecantLmOptions.refresh_every must be >= 1");
  if (!(tau > 0)) throw Error("SecantLmOptions.tau must be > 0");
  if (!(gradient_tolerance >= 0)) throw Error("SecantLmOptions.gradient_tolerance must be >= 0");
  if (!(step_tolerance >= 0)) throw Error("SecantLmOptions.step_tolerance must be >= 0");
  if (!(relative_decrease >= 0 && relative_decrease < 1))
    throw Error("SecantLmOptions.relative_decrease must be in [0, 1)");
  if (stall_iterations < 1) throw Error("SecantLmOptions.stall_iterations must be >= 1");
  if (!(finite_difference_step >= 0 && std::isfinite(finite_difference_step)))
    throw Error("SecantLmOptions.finite_difference_step must be >= 0 and finite");
  if (max_residual_evaluations < 0) throw Error("SecantLmOptions.max_residual_evaluations must be >= 0");
  if (!(max_step >= 0 && std::isfinite(max_step))) throw Error("SecantLmOptions.max_step must be >= 0 and finite");
}

namespace {

// One run of the solver: the state its iterations share (Madsen's notation: B the
// Jacobian approximation, g = Bᵀr, μ the damping, ν its growth on a rejected step).
class SecantLmRun {
 public:
  SecantLmRun(const LeastSquaresProblem& problem, Eigen::VectorXd& x, const SecantLmOptions& options)
      : problem_(problem),
        o_(options),
        n_(problem.NumParameters()),
        numeric_(options.finite_difference_step > 0),
        delta_(options.finite_difference_step),
        x_(x) {}

  SecantLmReport Solve();

 private:
  void Eval(const Eigen::VectorXd& at, Eigen::VectorXd& out) {
    problem_.Residuals(at, out);
    ++rep_.residual_evaluations;
  }
  void TimedEval(const Eigen::VectorXd& at, Eigen::VectorXd& out) {
    const auto t0 = Clock::now();
    Eval(at, out);
    rep_.residual_seconds += Since(t0);
  }
  // A fresh B at x: the analytic Jacobian or forward differences.
  void Fresh() {
    const auto t = Clock::now();
    if (numeric_)
      DifferenceJacobian([this](const Eigen::VectorXd& at, Eigen::VectorXd& out) { Eval(at, out); }, x_, r_, delta_,
                         B_);
    else
      problem_.Jacobian(x_, B_);
    rep_.jacobian_seconds += Since(t);
    ++rep_.fresh_jacobians;
  }
  Eigen::VectorXd DampedStep();
  void RefreshCoordinate(const Eigen::VectorXd& h);
  double TryStep(const Eigen::VectorXd& h, bool shortened);

  const LeastSquaresProblem& problem_;
  const SecantLmOptions& o_;
  const int n_;
  const bool numeric_;
  const double delta_;
  Eigen::VectorXd& x_;
  SecantLmReport rep_;
  Eigen::SparseMatrix<double, Eigen::RowMajor> B_;
  Eigen::VectorXd r_, g_;
  double F_ = 0;  // ½‖r‖²
  Eigen::SparseMatrix<double> I_, BtB_;
  bool btb_valid_ = true;
  double mu_ = 0, nu_ = 2;
  double radius_ = 0;  // current cap on ‖h‖ (max_step > 0)
  int stall_ = 0;
  int updates_since_fresh_ = 0;
  int coordinate_ = -1;  // Madsen's j (numeric mode)
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt_;
  bool analysed_ = false;
};

// The damped Gauss-Newton step h: (BᵀB + μI) h = −g.
Eigen::VectorXd SecantLmRun::DampedStep() {
  auto t0 = Clock::now();
  if (!btb_valid_) BtB_ = Eigen::SparseMatrix<double>(B_.transpose()) * B_;
  btb_valid_ = true;
  const Eigen::SparseMatrix<double> A = BtB_ + mu_ * I_;
  auto tp = Clock::now();
  rep_.product_seconds += Since(t0);
  // B keeps one pattern, so the ordering is computed once.
  if (!analysed_) ldlt_.analyzePattern(A), analysed_ = true;
  ldlt_.factorize(A);
  rep_.factor_seconds += Since(tp);
  if (ldlt_.info() != Eigen::Success) throw NumericalError("secant LM: factorisation failed");
  Eigen::VectorXd h = ldlt_.solve(-g_);
  rep_.solve_seconds += Since(t0);
  if (!h.allFinite()) throw NumericalError("secant LM: non-finite step");
  return h;
}

// Numeric secant mode: keep B good along every coordinate, refreshing column j unless h
// already probes it.
void SecantLmRun::RefreshCoordinate(const Eigen::VectorXd& h) {
  coordinate_ = (coordinate_ + 1) % n_;
  if (std::abs(h[coordinate_]) >= 0.8 * h.norm()) return;
  Eigen::VectorXd x_j = x_, r_j;
  x_j[coordinate_] += delta_;
  TimedEval(x_j, r_j);
  if (r_j.allFinite()) {
    SchubertUpdate(B_, x_j - x_, r_j - r_);
    ++rep_.secant_updates;
    btb_valid_ = false;
  }
}

// Evaluates x + h, updates B along h, takes the step if the gain ratio ρ is positive and
// adapts μ; returns ρ.
double SecantLmRun::TryStep(const Eigen::VectorXd& h, bool shortened) {
  const Eigen::VectorXd x_new = x_ + h;
  Eigen::VectorXd r_new;
  TimedEval(x_new, r_new);
  const double F_new = r_new.allFinite() ? 0.5 * r_new.squaredNorm() : HUGE_VAL;
  // Predicted decrease L(0) − L(h) = ½ hᵀ(μh − g) for the damped step itself; a step
  // shortened to max_step: −gᵀh − ½‖Bh‖² (the same model, evaluated directly).
  const double predicted = shortened ? -g_.dot(h) - 0.5 * (B_ * h).squaredNorm() : 0.5 * h.dot(mu_ * h - g_);
  const double rho = predicted > 0 ? (F_ - F_new) / predicted : -1;
  // The secant information along h is valid whether or not the step is taken.
  if (o_.secant && r_new.allFinite()) {
    SchubertUpdate(B_, h, r_new - r_);
    ++rep_.secant_updates;
    ++updates_since_fresh_;
    btb_valid_ = false;
  }
  if (rho > 0) {
    const double decrease = (F_ - F_new) / std::max(F_, 1e-300);
    x_ = x_new;
    r_ = r_new;
    F_ = F_new;
    ++rep_.accepted;
    mu_ *= std::max(1.0 / 3, 1 - std::pow(2 * rho - 1, 3));
    nu_ = 2;
    stall_ = decrease < o_.relative_decrease ? stall_ + 1 : 0;
  } else {
    ++rep_.rejected;
    mu_ *= nu_;
    nu_ *= 2;
  }
  return rho;
}

SecantLmReport SecantLmRun::Solve() {
  TimedEval(x_, r_);
  if (!r_.allFinite()) throw NumericalError("secant LM: non-finite initial residuals");
  Fresh();
  F_ = 0.5 * r_.squaredNorm();
  rep_.initial_cost = F_;
  g_ = B_.transpose() * r_;
  I_.resize(n_, n_);
  I_.setIdentity();
  BtB_ = Eigen::SparseMatrix<double>(B_.transpose()) * B_;
  mu_ = o_.tau * std::max(BtB_.diagonal().maxCoeff(), 1e-300);
  radius_ = o_.max_step;
  rep_.termination = "max_iterations";
  for (int k = 0; k < o_.max_iterations; ++k) {
    if (g_.lpNorm<Eigen::Infinity>() <= o_.gradient_tolerance) {
      rep_.termination = "gradient";
      break;
    }
    // An iteration costs one evaluation, two with a coordinate refresh.
    if (o_.max_residual_evaluations > 0 &&
        rep_.residual_evaluations + (numeric_ ? 2 : 1) > o_.max_residual_evaluations) {
      rep_.termination = "max_residual_evaluations";
      break;
    }
    Eigen::VectorXd h = DampedStep();
    const bool shortened = radius_ > 0 && h.norm() > radius_;
    if (shortened) h *= radius_ / h.norm(), ++rep_.shortened;
    rep_.iterations = k + 1;
    if (h.norm() <= o_.step_tolerance * (x_.norm() + o_.step_tolerance)) {
      rep_.termination = "step";
      rep_.cost.push_back(F_);
      break;
    }
    if (numeric_ && o_.secant) RefreshCoordinate(h);
    const double rho = TryStep(h, shortened);
    // The trust radius: back to max_step after a success, half the failed step after a
    // failure (for one residual μ only rescales the step, and slowly).
    if (o_.max_step > 0) radius_ = rho > 0 ? o_.max_step : 0.5 * std::min(radius_, h.norm());
    rep_.cost.push_back(F_);
    if (stall_ >= o_.stall_iterations) {
      rep_.termination = "relative_decrease";
      break;
    }
    const bool stale = updates_since_fresh_ > 0;
    // Numeric secant mode never refreshes in full (n evaluations): the coordinate
    // refresh keeps B current instead.
    const bool refresh =
        o_.secant ? (!numeric_ && (updates_since_fresh_ >= o_.refresh_every || (rho <= 0 && stale))) : rho > 0;
    if (refresh) {
      Fresh();
      updates_since_fresh_ = 0;
      btb_valid_ = false;
    }
    g_ = B_.transpose() * r_;
  }
  rep_.final_cost = F_;
  rep_.final_mu = mu_;
  return rep_;
}

}  // namespace

SecantLmReport SolveSecantLm(const LeastSquaresProblem& problem, Eigen::VectorXd& x, const SecantLmOptions& options) {
  options.Validate();
  DRAPE_CHECK(x.size() == problem.NumParameters(), "parameter vector size");
  return SecantLmRun(problem, x, options).Solve();
}

}  // namespace drape::optim
