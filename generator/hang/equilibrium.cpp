#include "generator/hang/equilibrium.h"

#include <kinsol/kinsol.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_spgmr.h>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>

#include "common/error.h"
#include "common/format.h"

namespace drape {

void EquilibriumOptions::Validate() const {
  if (!(relative_tolerance > 0 && relative_tolerance < 1))
    throw Error("equilibrium: relative_tolerance must be in (0, 1)");
  if (max_iterations < 1) throw Error("equilibrium: max_iterations must be >= 1");
  if (!(max_displacement > 0)) throw Error("equilibrium: max_displacement must be > 0");
}

namespace {
// Contact push (m of penetration) smoothed as a softplus of width gap/4: a kinked
// max(0, pen) made KINSOL's line search fail whenever contacts switched on or off.
double ContactPush(double pen, double gap) {
  const double e = gap / 4, z = pen / e;
  return z > 30 ? pen : e * std::log1p(std::exp(z));
}
double ContactSlope(double pen, double gap) {  // d push / d pen
  const double z = pen / (gap / 4);
  return z > 30 ? 1.0 : 1.0 / (1.0 + std::exp(-z));
}
}  // namespace

Points3 SpringForces(const SpringNetwork& net, const Points3& x) {
  const int n = net.NumNodes();
  Points3 f(n, 3);
  for (int i = 0; i < n; ++i) f.row(i) = net.mass[i] * net.gravity.transpose();
  for (size_t s = 0; s < net.springs.size(); ++s) {
    const auto [a, b] = net.springs[s];
    const Vec3 d = x.row(b) - x.row(a);
    const double l = d.norm();
    if (l <= 0) continue;
    const Vec3 fa = (net.stiffness[s] * (l - net.rest_length[s]) / (net.rest_length[s] * l)) * d;
    f.row(a) += fa.transpose();
    f.row(b) -= fa.transpose();
  }
  for (const auto& c : net.contacts) {
    Vec3 q = x.row(c.node).transpose();
    for (int j = 0; j < 3; ++j) q -= c.w[j] * x.row(c.tri[j]).transpose();
    const Vec3 fc = net.contact_stiffness * ContactPush(c.gap - c.dir.dot(q), c.gap) * c.dir;
    f.row(c.node) += fc.transpose();
    for (int j = 0; j < 3; ++j) f.row(c.tri[j]) -= c.w[j] * fc.transpose();
  }
  return f;
}

namespace {

struct Problem {
  const SpringNetwork* net;
  std::vector<int> free_nodes;  // unknown block k ↔ node free_nodes[k]
  std::vector<int> block;       // node → unknown block or −1
  Points3 x;                    // full positions, free rows overwritten from u
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  bool factor_ok = false;
  bool analysed = false;
  int eval_failures = 0;
  // Proximal term c·m_i·(u_ref − u) (s⁻²): regularises the slack directions while
  // continuation drives c to 0 (then the plain force balance is solved).
  double c = 0;
  std::vector<double> u_ref;

  double Slope(const SpringNetwork::Contact& c) const {
    Vec3 q = x.row(c.node).transpose();
    for (int j = 0; j < 3; ++j) q -= c.w[j] * x.row(c.tri[j]).transpose();
    return ContactSlope(c.gap - c.dir.dot(q), c.gap);
  }
  void Scatter(const double* u) {
    for (size_t k = 0; k < free_nodes.size(); ++k)
      x.row(free_nodes[k]) = Eigen::Map<const Eigen::RowVector3d>(u + 3 * k);
  }
  // 3×3 stiffness block K of spring s (∂f_a/∂x_b); tension_only clamps the geometric
  // term so the assembled matrix is positive semi-definite (preconditioner).
  Eigen::Matrix3d Block(size_t s, bool tension_only) const {
    const auto [a, b] = net->springs[s];
    const Vec3 d = x.row(b) - x.row(a);
    const double l = std::max(d.norm(), 1e-12);
    const Vec3 u = d / l;
    const double k = net->stiffness[s] / net->rest_length[s];
    double geo = 1.0 - net->rest_length[s] / l;
    if (tension_only) geo = std::max(geo, 0.0);
    const Eigen::Matrix3d uu = u * u.transpose();
    return k * (uu + geo * (Eigen::Matrix3d::Identity() - uu));
  }
};

int Residual(N_Vector uu, N_Vector fval, void* data) {
  auto* p = static_cast<Problem*>(data);
  const double* u = N_VGetArrayPointer(uu);
  for (sunindextype i = 0; i < N_VGetLength(uu); ++i)
    if (!std::isfinite(u[i])) return 1;  // recoverable: line search backs off
  p->Scatter(u);
  const Points3 f = SpringForces(*p->net, p->x);
  double* out = N_VGetArrayPointer(fval);
  for (size_t k = 0; k < p->free_nodes.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      out[3 * k + c] = f(p->free_nodes[k], c);
      if (p->c > 0) out[3 * k + c] += p->c * p->net->mass[p->free_nodes[k]] * (p->u_ref[3 * k + c] - u[3 * k + c]);
    }
  return 0;
}

int JacTimes(N_Vector v, N_Vector jv, N_Vector uu, sunbooleantype* new_uu, void* data) {
  auto* p = static_cast<Problem*>(data);
  p->Scatter(N_VGetArrayPointer(uu));
  const double* vin = N_VGetArrayPointer(v);
  double* out = N_VGetArrayPointer(jv);
  std::fill(out, out + N_VGetLength(jv), 0.0);
  const auto& net = *p->net;
  for (size_t s = 0; s < net.springs.size(); ++s) {
    const int ba = p->block[net.springs[s][0]], bb = p->block[net.springs[s][1]];
    if (ba < 0 && bb < 0) continue;
    // Exact Jacobian (the tension-only one converges only linearly, ~0.9 per step, in
    // the slack directions of buckled cloth); the preconditioner uses tension-only.
    const Eigen::Matrix3d K = p->Block(s, false);
    Vec3 dv = Vec3::Zero();  // v_b − v_a
    if (bb >= 0) dv += Eigen::Map<const Vec3>(vin + 3 * bb);
    if (ba >= 0) dv -= Eigen::Map<const Vec3>(vin + 3 * ba);
    const Vec3 kd = K * dv;
    if (ba >= 0) Eigen::Map<Vec3>(out + 3 * ba) += kd;
    if (bb >= 0) Eigen::Map<Vec3>(out + 3 * bb) -= kd;
  }
  // Contacts: J = −k·σ·g·gᵀ with g = (dir at the node, −w_j·dir at the triangle).
  for (const auto& c : net.contacts) {
    const double sigma = p->Slope(c);
    const int nodes[4] = {c.node, c.tri[0], c.tri[1], c.tri[2]};
    const double coef[4] = {1.0, -c.w[0], -c.w[1], -c.w[2]};
    double gv = 0;
    for (int t = 0; t < 4; ++t) {
      const int b = p->block[nodes[t]];
      if (b >= 0) gv += coef[t] * c.dir.dot(Eigen::Map<const Vec3>(vin + 3 * b));
    }
    for (int t = 0; t < 4; ++t) {
      const int b = p->block[nodes[t]];
      if (b >= 0) Eigen::Map<Vec3>(out + 3 * b) -= sigma * net.contact_stiffness * gv * coef[t] * c.dir;
    }
  }
  if (p->c > 0)
    for (size_t k = 0; k < p->free_nodes.size(); ++k)
      for (int c = 0; c < 3; ++c) out[3 * k + c] -= p->c * net.mass[p->free_nodes[k]] * vin[3 * k + c];
  *new_uu = SUNFALSE;
  return 0;
}

int PrecSetup(N_Vector uu, N_Vector, N_Vector, N_Vector, void* data) {
  auto* p = static_cast<Problem*>(data);
  p->Scatter(N_VGetArrayPointer(uu));
  const auto& net = *p->net;
  const int n3 = 3 * static_cast<int>(p->free_nodes.size());
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(net.springs.size() * 36);
  double diag_sum = 0;
  for (size_t s = 0; s < net.springs.size(); ++s) {
    const int ba = p->block[net.springs[s][0]], bb = p->block[net.springs[s][1]];
    if (ba < 0 && bb < 0) continue;
    const Eigen::Matrix3d K = p->Block(s, true);
    diag_sum += 2 * K.trace();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        if (ba >= 0) t.emplace_back(3 * ba + r, 3 * ba + c, K(r, c));
        if (bb >= 0) t.emplace_back(3 * bb + r, 3 * bb + c, K(r, c));
        if (ba >= 0 && bb >= 0) {
          t.emplace_back(3 * ba + r, 3 * bb + c, -K(r, c));
          t.emplace_back(3 * bb + r, 3 * ba + c, -K(r, c));
        }
      }
  }
  for (const auto& c : net.contacts) {
    const double on = p->Slope(c);  // never exactly 0: the pattern stays fixed
    const int nodes[4] = {c.node, c.tri[0], c.tri[1], c.tri[2]};
    const double coef[4] = {1.0, -c.w[0], -c.w[1], -c.w[2]};
    const Eigen::Matrix3d D = on * net.contact_stiffness * c.dir * c.dir.transpose();
    for (int s1 = 0; s1 < 4; ++s1)
      for (int s2 = 0; s2 < 4; ++s2) {
        const int b1 = p->block[nodes[s1]], b2 = p->block[nodes[s2]];
        if (b1 < 0 || b2 < 0) continue;
        for (int r = 0; r < 3; ++r)
          for (int q = 0; q < 3; ++q) t.emplace_back(3 * b1 + r, 3 * b2 + q, coef[s1] * coef[s2] * D(r, q));
      }
  }
  // Small shift: slack (untensioned) directions have no stiffness at all.
  const double shift = 1e-6 * diag_sum / std::max(n3, 1);
  for (int i = 0; i < n3; ++i) t.emplace_back(i, i, shift + p->c * net.mass[p->free_nodes[i / 3]]);
  Eigen::SparseMatrix<double> A(n3, n3);
  A.setFromTriplets(t.begin(), t.end());
  // The sparsity pattern never changes: order and analyse once, factorise each time.
  if (!p->analysed) {
    p->ldlt.analyzePattern(A);
    p->analysed = true;
  }
  p->ldlt.factorize(A);
  p->factor_ok = p->ldlt.info() == Eigen::Success;
  return p->factor_ok ? 0 : 1;
}

int PrecSolve(N_Vector, N_Vector, N_Vector, N_Vector, N_Vector vv, void* data) {
  auto* p = static_cast<Problem*>(data);
  if (!p->factor_ok) return 1;
  Eigen::Map<Eigen::VectorXd> v(N_VGetArrayPointer(vv), N_VGetLength(vv));
  // J ≈ −A (forces decrease as nodes move along the springs' pull).
  Eigen::VectorXd z = p->ldlt.solve(v);
  v = -z;
  return 0;
}

void SilentErrors(int, const char*, const char*, char*, void*) {}

struct SundialsDeleter {
  void operator()(SUNContext c) const { SUNContext_Free(&c); }
};

}  // namespace

EquilibriumReport SolveEquilibrium(const SpringNetwork& net, Points3& x,
                                   const EquilibriumOptions& options) {
  options.Validate();
  const int n = net.NumNodes();
  DRAPE_CHECK(x.rows() == n && static_cast<int>(net.fixed.size()) == n, "sizes");
  EquilibriumReport report;
  const double g = net.gravity.norm();

  Problem p;
  p.net = &net;
  p.x = x;
  p.block.assign(n, -1);
  for (int i = 0; i < n; ++i)
    if (!net.fixed[i]) {
      p.block[i] = static_cast<int>(p.free_nodes.size());
      p.free_nodes.push_back(i);
    }
  auto measure = [&](const Points3& pos, double& abs_max, double& rel_max) {
    const Points3 f = SpringForces(net, pos);
    abs_max = rel_max = 0;
    for (int i : p.free_nodes) {
      const double fn = f.row(i).norm();
      abs_max = std::max(abs_max, fn);
      rel_max = std::max(rel_max, fn / (net.mass[i] * g));
    }
  };
  measure(x, report.residual_before, report.relative_before);
  report.residual_after = report.residual_before;
  report.relative_after = report.relative_before;
  if (p.free_nodes.empty()) {
    report.converged = true;
    report.message = "no free nodes";
    return report;
  }

  SUNContext raw_ctx = nullptr;
  if (SUNContext_Create(nullptr, &raw_ctx) != 0) throw NumericalError("SUNContext_Create failed");
  std::unique_ptr<std::remove_pointer_t<SUNContext>, SundialsDeleter> ctx(raw_ctx);
  const sunindextype m = 3 * static_cast<sunindextype>(p.free_nodes.size());
  N_Vector u = N_VNew_Serial(m, raw_ctx), uscale = N_VNew_Serial(m, raw_ctx),
           fscale = N_VNew_Serial(m, raw_ctx);
  double* ud = N_VGetArrayPointer(u);
  double* fs = N_VGetArrayPointer(fscale);
  for (size_t k = 0; k < p.free_nodes.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      ud[3 * k + c] = x(p.free_nodes[k], c);
      fs[3 * k + c] = 1.0 / (net.mass[p.free_nodes[k]] * g);  // residual relative to weight
    }
  N_VConst(1.0, uscale);
  // Proximal continuation: solve F(u) + c·M·(u_ref − u) = 0 for decreasing c, each
  // from the last solution (u_ref updated), ending with c = 0. Starting far from
  // equilibrium (Bullet's PBD stretch differs from the spring model's), plain Newton
  // wanders along the buckling modes of slack cloth; the proximal term makes each stage
  // well posed. After every stage the plain force balance is measured; we stop as soon
  // as it meets the tolerance, and keep the stage with the smallest plain residual.
  // c0: the proximal spring as stiff as the cloth's own (it must outweigh the negative
  // stiffness of compressed springs); then down by 5× per stage to where a node's
  // weight would move it ~1 m.
  double ksum = 0, msum = 0;
  for (size_t s = 0; s < net.springs.size(); ++s) ksum += 2 * net.stiffness[s] / net.rest_length[s];
  for (int i : p.free_nodes) msum += net.mass[i];
  const double c0 = ksum / std::max(msum, 1e-12);
  std::vector<double> schedule;
  for (double c = c0; c > g; c *= 0.2) schedule.push_back(c);
  schedule.push_back(0);
  std::vector<double> best(ud, ud + m), saved;
  double best_rel = report.relative_before;
  int flag = KIN_SUCCESS, best_flag = KIN_SUCCESS;
  for (size_t stage = 0; stage < schedule.size() && best_rel > options.relative_tolerance &&
                         report.iterations < options.max_total_iterations;
       ++stage) {
    p.c = schedule[stage];
    p.u_ref.assign(ud, ud + m);
    saved = p.u_ref;
    void* kin = KINCreate(raw_ctx);
    SUNLinearSolver ls = SUNLinSol_SPGMR(u, SUN_PREC_RIGHT, 40, raw_ctx);
    flag = KINInit(kin, Residual, u);
    if (flag == KIN_SUCCESS) {
      KINSetUserData(kin, &p);
      KINSetErrHandlerFn(kin, SilentErrors, nullptr);
      KINSetPrintLevel(kin, 0);
      // KINSOL's test is on the max-norm of components; per node |F| ≤ √3 × that.
      // Intermediate stages only need to be roughly solved (they are a path to the
      // final c = 0 stage); tight solves of every stage cost 5–10× more at 2k nodes.
      const bool final_stage = p.c == 0;
      KINSetFuncNormTol(kin, (final_stage ? 0.3 * options.relative_tolerance : 1e-2) / std::sqrt(3.0));
      KINSetScaledStepTol(kin, 1e-13);
      const int budget = options.max_total_iterations - report.iterations;
      KINSetNumMaxIters(kin, std::max(1, std::min(final_stage ? options.max_iterations : 8, budget)));
      // Refactorise the preconditioner every 5 Newton steps: the LDLᵀ factorisation is
      // ~60 % of the solve at 2k nodes (perf), GMRES absorbs a slightly stale one.
      KINSetMaxSetupCalls(kin, 5);
      KINSetLinearSolver(kin, ls, nullptr);
      KINSetJacTimesVecFn(kin, JacTimes);
      KINSetPreconditioner(kin, PrecSetup, PrecSolve);
      flag = KINSol(kin, u, KIN_LINESEARCH, uscale, fscale);
    }
    long nni = 0, nli = 0;
    KINGetNumNonlinSolvIters(kin, &nni);
    KINGetNumLinIters(kin, &nli);
    report.iterations += static_cast<int>(nni);
    report.linear_iterations += static_cast<int>(nli);
    KINFree(&kin);
    SUNLinSolFree(ls);
    // A stage out of iterations still made progress; only a failed line search or a
    // bad state sends us back to the stage's start.
    const bool ok = (flag == KIN_SUCCESS || flag == KIN_INITIAL_GUESS_OK || flag == KIN_MAXITER_REACHED) &&
                    std::isfinite(N_VMaxNorm(u));
    if (!ok) {  // a failed stage: back to its start; smaller c would be harder still
      std::copy(saved.begin(), saved.end(), ud);
      break;
    }
    p.Scatter(ud);
    double abs_now = 0, rel_now = 0;
    measure(p.x, abs_now, rel_now);
    if (rel_now < best_rel) {
      best_rel = rel_now;
      best.assign(ud, ud + m);
      best_flag = flag;
    }
  }
  std::copy(best.begin(), best.end(), ud);
  report.converged = best_rel <= options.relative_tolerance;
  if (!report.converged) flag = flag == KIN_SUCCESS ? best_flag : flag;

  Points3 sol = x;
  for (size_t k = 0; k < p.free_nodes.size(); ++k)
    sol.row(p.free_nodes[k]) = Eigen::Map<const Eigen::RowVector3d>(ud + 3 * k);
  N_VDestroy(u);
  N_VDestroy(uscale);
  N_VDestroy(fscale);

  bool finite = sol.allFinite();
  report.max_displacement = finite ? (sol - x).rowwise().norm().maxCoeff() : INFINITY;
  double abs_after = 0, rel_after = 0;
  if (finite) measure(sol, abs_after, rel_after);
  // A solve that stalls short of the tolerance (slack cloth: long, flat valleys) still
  // counts when it cut the residual tenfold: the state is then closer to stationary
  // than Bullet's, and the residual reported says how close.
  const bool improved = finite && rel_after < 0.1 * report.relative_before;
  if (!report.converged && !improved) {
    report.message = "not converged: best max |F|/(m g) " + FormatNumber(best_rel) + ", last KINSol flag " +
                     std::to_string(flag);
  } else if (report.max_displacement > options.max_displacement) {
    report.message = "solution moved a node " + FormatNumber(report.max_displacement) +
                     " m (limit " + FormatNumber(options.max_displacement) + ")";
  } else {
    x = sol;
    report.applied = true;
    report.residual_after = abs_after;
    report.relative_after = rel_after;
    report.message = report.converged ? "converged"
                                      : "partial: residual cut " + FormatNumber(report.relative_before / rel_after) +
                                            "x, last KINSol flag " + std::to_string(flag);
  }
  return report;
}

}  // namespace drape
