#include "runtime/registration/registration.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/error.h"
#include "common/field_error.h"
#include "common/timing.h"

namespace drape::registration {

namespace {

class EnergyProblem : public optim::LeastSquaresProblem {
 public:
  explicit EnergyProblem(const RegistrationEnergy& e) : e_(e) {}
  int NumResiduals() const override { return e_.NumResiduals(); }
  int NumParameters() const override { return e_.NumParameters(); }
  void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override { e_.Residuals(x, r); }
  void Jacobian(const Eigen::VectorXd& x, SparseRowMatrix& J) const override { e_.Jacobian(x, J); }

 private:
  const RegistrationEnergy& e_;
};

void CheckMesh(const TriMesh& m, const char* what) {
  if (m.NumFaces() == 0) throw Error(std::string("registration: ") + what + " mesh has no faces");
  if (!m.V.allFinite()) throw Error(std::string("registration: ") + what + " mesh has non-finite vertices");
  for (int f = 0; f < m.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k)
      if (m.F(f, k) < 0 || m.F(f, k) >= m.NumVertices())
        throw Error(std::string("registration: ") + what + " mesh face " + std::to_string(f) +
                    " has an out-of-range vertex index");
}
}  // namespace

void RegistrationOptions::Validate() const {
  grid.Validate();
  icp.Validate();
  lm.Validate();
  if (!(kappa >= 0 && std::isfinite(kappa))) BadField(kappa, "kappa", "must be >= 0 and finite");
  if (!(beta >= 0 && std::isfinite(beta))) BadField(beta, "beta", "must be >= 0 and finite");
  if (!(alpha >= 0 && std::isfinite(alpha))) BadField(alpha, "alpha", "must be >= 0 and finite");
}

RegistrationResult Register(const TriMesh& source, const TriMesh& target, const RegistrationOptions& options) {
  options.Validate();
  CheckMesh(source, "source");
  CheckMesh(target, "target");
  const auto t_all = Clock::now();
  RegistrationResult res;
  RegistrationReport& rep = res.report;

  rep.source_frame = AreaWeightedFrame(source);
  rep.target_frame = AreaWeightedFrame(target);
  if (options.scale) {
    rep.scaling = ScaleToTarget(rep.source_frame, rep.target_frame);
  }
  res.rigid.F = source.F;
  res.rigid.V = rep.scaling.Apply(source.V);

  auto t0 = Clock::now();
  const ClosestPointGrid grid(target, options.grid);
  rep.grid = grid.stats();
  rep.grid_seconds = Since(t0);

  t0 = Clock::now();
  const Similarity icp = Icp(res.rigid.V, grid, options.icp, &rep.icp);
  rep.rigid = icp.After(rep.scaling);
  rep.icp_seconds = Since(t0);
  if (!rep.icp.converged && options.icp.max_iterations > 0)
    rep.warnings.push_back("ICP did not converge in " + std::to_string(options.icp.max_iterations) + " iterations");

  res.nonrigid = res.rigid;
  t0 = Clock::now();
  ClosestPointFn fn = options.refined_fit ? ClosestPointFn([&grid](const Vec3& p) { return grid.QueryRefined(p); })
                                          : ClosestPointFn([&grid](const Vec3& p) { return grid.Query(p); });
  const RegistrationEnergy energy(res.rigid, fn, EnergyWeights{options.kappa, options.beta, options.alpha});
  rep.hinges = energy.NumHinges();
  Eigen::VectorXd x = RegistrationEnergy::Flatten(res.rigid.V);
  rep.energy_before = energy.Terms(x);
  if (options.nonrigid) {
    rep.lm = optim::SolveSecantLm(EnergyProblem(energy), x, options.lm);
    res.nonrigid.V = RegistrationEnergy::Unflatten(x);
    rep.energy_after = energy.Terms(x);
  } else {
    rep.energy_after = rep.energy_before;
  }
  rep.nonrigid_seconds = Since(t0);
  rep.total_seconds = Since(t_all);
  return res;
}

namespace {
// Area-weighted distances to `to` of the patches of `from`, or of those whose barycentre
// lies within `radius` of one of `centres` when radius >= 0; their area in `total` (over
// every patch: the reduction MeasureDirected always had).
DirectedDistance MeasurePatches(const TriMesh& from, const ExactClosestPoint& to, const std::vector<Vec3>& centres,
                                double radius, double& total) {
  const Eigen::VectorXd a = FaceAreas(from);
  const Points3 g = FaceCentroids(from);
  DirectedDistance d;
  double s = 0, ss = 0, near = 0;
  const double r2 = radius * radius;
  for (int f = 0; f < from.NumFaces(); ++f) {
    const Vec3 c = g.row(f);
    if (radius >= 0 &&
        std::none_of(centres.begin(), centres.end(), [&](const Vec3& x) { return (c - x).squaredNorm() <= r2; }))
      continue;
    const double dist = to.Query(c).distance;
    s += a[f] * dist;
    ss += a[f] * dist * dist;
    near += a[f];
    d.max = std::max(d.max, dist);
    ++d.samples;
  }
  total = radius >= 0 ? near : a.sum();
  if (total > 0) {
    d.mean = s / total;
    d.rms = std::sqrt(ss / total);
  }
  return d;
}
}  // namespace

DirectedDistance MeasureDirected(const TriMesh& from, const ExactClosestPoint& to) {
  double total = 0;
  const DirectedDistance d = MeasurePatches(from, to, {}, -1, total);
  if (!(total > 0)) throw Error("registration metric: mesh has no area");
  return d;
}

DirectedDistance MeasureDirectedNear(const TriMesh& from, const ExactClosestPoint& to, const Vec3& centre,
                                     double radius) {
  if (!(radius >= 0)) throw Error("registration metric: radius must be >= 0");
  double total = 0;
  return MeasurePatches(from, to, {centre}, radius, total);
}

std::vector<AnchorTransfer> TransferAnchors(const RegistrationResult& result, const std::vector<AnchorPair>& anchors) {
  std::vector<AnchorTransfer> out;
  for (const AnchorPair& a : anchors) {
    if (a.source_vertex < 0 || a.source_vertex >= result.rigid.NumVertices())
      throw Error("registration: anchor '" + a.label + "' has vertex " + std::to_string(a.source_vertex) +
                  " outside the source mesh (" + std::to_string(result.rigid.NumVertices()) + " vertices)");
    AnchorTransfer t;
    t.label = a.label;
    t.source_vertex = a.source_vertex;
    t.rigid = result.rigid.V.row(a.source_vertex);
    t.nonrigid = result.nonrigid.V.row(a.source_vertex);
    t.has_truth = a.has_truth;
    if (a.has_truth) {
      t.error_rigid = (t.rigid - a.truth).norm();
      t.error_nonrigid = (t.nonrigid - a.truth).norm();
    }
    out.push_back(t);
  }
  return out;
}

double SymmetricFit(const TriMesh& registered, const TriMesh& target, const ExactClosestPoint& onto_target) {
  const ExactClosestPoint onto_registered(registered);
  return 0.5 * (MeasureDirected(registered, onto_target).mean + MeasureDirected(target, onto_registered).mean);
}

RegistrationEvaluation RegisterAndEvaluate(const TriMesh& source, const TriMesh& target,
                                           const std::vector<AnchorPair>& anchors, const RegistrationOptions& options,
                                           RegistrationResult* result) {
  RegistrationEvaluation ev;
  const auto t0 = Clock::now();
  RegistrationResult res = Register(source, target, options);
  ev.seconds = Since(t0);
  ev.report = res.report;
  const ExactClosestPoint target_q(target), rigid_q(res.rigid), nonrigid_q(res.nonrigid);
  ev.s_to_t_rigid = MeasureDirected(res.rigid, target_q);
  ev.t_to_s_rigid = MeasureDirected(target, rigid_q);
  ev.s_to_t_nonrigid = MeasureDirected(res.nonrigid, target_q);
  ev.t_to_s_nonrigid = MeasureDirected(target, nonrigid_q);
  ev.anchors = TransferAnchors(res, anchors);
  for (const AnchorTransfer& a : ev.anchors) {
    if (!a.has_truth) continue;
    ++ev.anchors_with_truth;
    ev.anchor_error_rigid += a.error_rigid;
    ev.anchor_error_nonrigid += a.error_nonrigid;
  }
  if (ev.anchors_with_truth > 0) {
    ev.anchor_error_rigid /= ev.anchors_with_truth;
    ev.anchor_error_nonrigid /= ev.anchors_with_truth;
  }
  if (result) *result = std::move(res);
  return ev;
}

namespace {
Json Terms(const EnergyTerms& e) {
  return Json{{"fit", e.fit}, {"area", e.area}, {"angle", e.angle}, {"hinge", e.hinge}, {"total", e.total()}};
}
Json Directed(const DirectedDistance& d) {
  return Json{{"mean", d.mean}, {"rms", d.rms}, {"max", d.max}, {"samples", d.samples}};
}
}  // namespace

Json ToJson(const RegistrationReport& r) {
  Json j;
  j["source"] =
      Json{{"centre", PointJson(r.source_frame.centre)}, {"size", r.source_frame.size}, {"area", r.source_frame.area}};
  j["target"] =
      Json{{"centre", PointJson(r.target_frame.centre)}, {"size", r.target_frame.size}, {"area", r.target_frame.area}};
  Json m = Json::array();
  const Eigen::Matrix4d M = r.rigid.Matrix();
  for (int i = 0; i < 4; ++i) m.push_back(Json::array({M(i, 0), M(i, 1), M(i, 2), M(i, 3)}));
  j["scale"] = r.scaling.scale;
  j["rigid_transform"] = m;
  j["grid"] = Json{{"dims", Json::array({r.grid.nx, r.grid.ny, r.grid.nz})},
                   {"spacing", r.grid.spacing},
                   {"band_nodes", r.grid.band_nodes},
                   {"passes", r.grid.passes},
                   {"sweep_updates", r.grid.sweep_updates}};
  j["icp"] = Json{{"iterations", r.icp.iterations},
                  {"converged", r.icp.converged},
                  {"rms_before", r.icp.rms_before},
                  {"rms_after", r.icp.rms_after}};
  j["lm"] = Json{{"iterations", r.lm.iterations},
                 {"accepted", r.lm.accepted},
                 {"rejected", r.lm.rejected},
                 {"fresh_jacobians", r.lm.fresh_jacobians},
                 {"secant_updates", r.lm.secant_updates},
                 {"initial_cost", r.lm.initial_cost},
                 {"final_cost", r.lm.final_cost},
                 {"termination", r.lm.termination}};
  j["energy_before"] = Terms(r.energy_before);
  j["energy_after"] = Terms(r.energy_after);
  j["hinges"] = r.hinges;
  j["warnings"] = r.warnings;
  j["timing"] = Json{{"grid_seconds", r.grid_seconds},
                     {"icp_seconds", r.icp_seconds},
                     {"nonrigid_seconds", r.nonrigid_seconds},
                     {"total_seconds", r.total_seconds}};
  return j;
}

Json ToJson(const RegistrationEvaluation& ev) {
  Json j;
  j["s_to_t_rigid"] = Directed(ev.s_to_t_rigid);
  j["t_to_s_rigid"] = Directed(ev.t_to_s_rigid);
  j["s_to_t_nonrigid"] = Directed(ev.s_to_t_nonrigid);
  j["t_to_s_nonrigid"] = Directed(ev.t_to_s_nonrigid);
  Json a = Json::array();
  for (const AnchorTransfer& t : ev.anchors) {
    Json e{{"label", t.label},
           {"vertex", t.source_vertex},
           {"rigid", PointJson(t.rigid)},
           {"nonrigid", PointJson(t.nonrigid)}};
    if (t.has_truth) e["error_rigid"] = t.error_rigid, e["error_nonrigid"] = t.error_nonrigid;
    a.push_back(e);
  }
  j["anchors"] = a;
  if (ev.anchors_with_truth > 0) {
    j["anchor_error_rigid"] = ev.anchor_error_rigid;
    j["anchor_error_nonrigid"] = ev.anchor_error_nonrigid;
  }
  j["report"] = ToJson(ev.report);
  j["timing"] = Json{{"seconds", ev.seconds}};
  return j;
}

}  // namespace drape::registration
