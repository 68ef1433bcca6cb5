// The plan phase (trial.h): recognition's top database entries registered onto the
// reconstruction (candidates.h), the best rigid fit kept, its plan by the objective f
// (Eq. finalobj) and the regrasp point: its registered target mapped onto the
// reconstruction, or the reconstruction's lowest point, or the point above a hanging end.
#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "common/field_error.h"
#include "common/timing.h"
#include "runtime/recognition/category_fit.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/unfolding/trial.h"

namespace drape::unfolding {

namespace rec = drape::recognition;
namespace hw = drape::hardware;

void PlanOptions::Validate() const {
  objective.Validate();
  lowest.Validate();
  hanging.Validate();
  if (candidates < 1 || candidates > 10) BadField(candidates, "PlanOptions.candidates", "must be in 1..10");
}

// The candidates' registrations, what the plan keeps of each, and the holder's frame.
struct Trial::Registered {
  std::vector<CandidateRegistration> regs;
  std::vector<int> vertex;    // each candidate's target anchor vertex; -1: not usable
  std::vector<double> fits;   // the fit that selects (rigid); -1: not usable
  std::string first_failure;  // why the first unusable candidate could not be used
  bool nonrigid_kept_only = false;
  Eigen::Matrix3d to_world = Eigen::Matrix3d::Identity();  // object frame → world: the holder's wrist
  Vec3 origin = Vec3::Zero();                              // the holder's jaw centre
};

namespace {
// Candidate registration `reg`'s anchor vertex `v` as the regrasp point: mapped onto the
// reconstruction (its closest surface point; object frame).
Vec3 Predict(const CandidateRegistration& reg, int v, const ExactClosestPoint& onto) {
  return onto.Query(reg.final_mesh().V.row(v).transpose()).point;
}
}  // namespace

bool Trial::Plan(Step& s) {
  Recognised& r = s.recognise;
  const std::vector<DesiredPair> pairs = DesiredPairsFor(r.recognition.category);
  if (pairs.empty()) {
    res_.failure = "recognised as '" + r.recognition.category + "', which has no desired anchor pair";
    return false;
  }
  const auto t0 = Clock::now();
  const std::vector<rec::Candidate> cands =
      RegistrationCandidates(r.recognition, r.prior_rank >= 0 || r.prior_trusted,
                             r.category_switched ? "" : r.aimed_anchor, o_.plan.candidates);
  r.recognition.entries.clear();  // the trace lists the candidates
  const ExactClosestPoint onto(s.observe.recon);
  Registered reg;
  const hw::GripperPose hp = world_.arm(holder_).pose();
  reg.to_world = Eigen::AngleAxisd(hp.wrist, Vec3::UnitY()).toRotationMatrix();
  reg.origin = hp.position;
  // The rigid fit selects and the kept candidate's point is used: only it needs R + N.
  reg.nonrigid_kept_only = o_.plan.nonrigid && cands.size() > 1;
  RegisterCandidates(s, cands, pairs, onto, reg);
  Planned& p = s.plan;
  p.kept = KeepCandidate(reg.fits);
  if (p.kept >= 0 && reg.nonrigid_kept_only) NonrigidForKept(s, onto, reg);
  res_.times.registration += Since(t0);
  if (p.kept < 0) {
    res_.failure = reg.first_failure;
    return false;
  }
  const CandidateTrace& k = p.candidates[p.kept];
  const CandidateRegistration& kept = reg.regs[p.kept];
  s.truth.kept_right = k.truth.right;
  r.recognition.best = k.candidate;
  r.recognition.anchor = k.candidate.anchor;
  p.current_anchor = k.candidate.anchor;
  p.next_anchor = k.next_anchor;
  p.f = k.f;
  p.registered = kept.final_mesh();
  p.icp_rms = k.icp_rms;
  if (!kept.note.empty()) s.note = kept.note;
  ColourByScore(s, pairs);
  PointFromKept(s, kept, reg.vertex[p.kept], reg);
  return true;
}

// Each candidate's database mesh (turned by its recognised rotation) registered onto the
// reconstruction, its plan and its next anchor mapped onto the reconstruction.
void Trial::RegisterCandidates(Step& s, const std::vector<rec::Candidate>& cands, const std::vector<DesiredPair>& pairs,
                               const ExactClosestPoint& onto, Registered& r) const {
  r.regs.resize(cands.size());
  r.vertex.assign(cands.size(), -1);
  r.fits.assign(cands.size(), -1);
  const std::string& held = s.truth.held_anchor;
  const std::vector<std::string> twins = rec::SymmetryTwins(held);
  for (size_t i = 0; i < cands.size(); ++i) {
    const auto tc = Clock::now();
    CandidateTrace t;
    t.candidate = cands[i];
    t.truth.right = cands[i].category == category_ && cands[i].anchor == held;
    t.truth.twin =
        cands[i].category == category_ && std::find(twins.begin(), twins.end(), cands[i].anchor) != twins.end();
    if (t.truth.right && s.truth.true_rank < 0) s.truth.true_rank = static_cast<int>(i);
    std::string why;
    t.next_anchor = PlanFrom(cands[i], pairs, &t.f, &why);
    if (t.next_anchor.empty()) {
      t.note = why;
      if (r.first_failure.empty()) r.first_failure = why;
      s.plan.candidates.push_back(std::move(t));
      continue;
    }
    CandidateRegistration& reg = r.regs[i];
    reg = RegisterCandidate(TurnedSource(cands[i]), s.observe.recon, onto, o_.plan.nonrigid && !r.nonrigid_kept_only);
    t.note = reg.note;
    t.icp_rms = reg.reg.report.icp.rms_after;
    t.fit_rigid = reg.fit_rigid;
    t.fit_final = r.nonrigid_kept_only ? -1 : reg.fit_final;
    const int v = model_.AnchorVertex(cands[i].instance, t.next_anchor);
    if (v < 0 || v >= reg.final_mesh().NumVertices()) {
      t.note = "the database has no vertex for anchor " + t.next_anchor + " of " + cands[i].instance;
      if (r.first_failure.empty()) r.first_failure = t.note;
    } else {
      r.vertex[i] = v;
      t.usable = true;
      r.fits[i] = t.fit_rigid;
      t.predicted = r.to_world * Predict(reg, v, onto) + r.origin;
    }
    t.seconds = Since(tc);
    s.plan.candidates.push_back(std::move(t));
  }
}

// R + N for the kept candidate only (the others were registered rigidly: the rigid fit
// selected it and its own point is used). The same registration as R + N for all
// (Register is deterministic), without the other candidates' non-rigid steps.
void Trial::NonrigidForKept(Step& s, const ExactClosestPoint& onto, Registered& r) const {
  const auto tc = Clock::now();
  const int k = s.plan.kept;
  CandidateTrace& t = s.plan.candidates[k];
  CandidateRegistration& reg = r.regs[k];
  reg = RegisterCandidate(TurnedSource(t.candidate), s.observe.recon, onto, true);
  t.note = reg.note;
  t.fit_final = reg.fit_final;
  const int v = model_.AnchorVertex(t.candidate.instance, t.next_anchor);
  DRAPE_CHECK(v >= 0 && v < reg.final_mesh().NumVertices(), "the kept candidate has no anchor vertex");
  t.predicted = r.to_world * Predict(reg, v, onto) + r.origin;
  t.seconds += Since(tc);
}

// The next anchor by the objective f over the recognised category's desired pairs, from
// candidate `c`'s anchor on its instance. "" (with `why`) when no anchor is far enough.
std::string Trial::PlanFrom(const rec::Candidate& c, const std::vector<DesiredPair>& pairs, double* f,
                            std::string* why) const {
  const ScoreTable table(model_.InstanceAnchors(c.instance), pairs, o_.plan.objective);
  const int current = table.IndexOf(c.anchor);
  DRAPE_CHECK(current >= 0, "recognised anchor not among its instance's anchors");
  const ScoreTable::Next next = table.BestNext(current);
  if (next.anchor < 0) {
    *why = "no anchor of " + c.instance + " is far enough from " + c.anchor + " to regrasp";
    return "";
  }
  *f = next.f;
  return table.anchor(next.anchor).label;
}

// Score colouring of the registered mesh (pictures): each vertex's pattern point is
// unknown here, so colour by its distance to the desired anchors' registered vertices.
void Trial::ColourByScore(Step& s, const std::vector<DesiredPair>& pairs) const {
  const std::string& instance = s.recognise.recognition.best.instance;
  const TriMesh& m = s.plan.registered;
  std::vector<double>& score = s.plan.point_score;
  score.assign(m.NumVertices(), 0.0);
  const double sigma = o_.plan.objective.sigma_length;
  for (const DesiredPair& d : pairs) {
    for (const std::string& lab : {d.first, d.second}) {
      const int av = model_.AnchorVertex(instance, lab);
      if (av < 0 || av >= m.NumVertices()) continue;
      const Vec3 c = m.V.row(av);
      const double sig = 1.0 / (2 * sigma * sigma);
      for (int i = 0; i < m.NumVertices(); ++i)
        score[i] = std::max(score[i], std::exp(-sig * (m.V.row(i).transpose() - c).squaredNorm()));
    }
  }
}

// Candidate `c`'s database mesh turned by its recognised rotation.
TriMesh Trial::TurnedSource(const rec::Candidate& c) const {
  return rec::TurnedToQuery(model_.HungMesh(c.entry), c.rotation, model_.database().sectors());
}

// The regrasp point from the kept candidate's registration `reg` (its target at vertex
// `v`): the registered target mapped onto the reconstruction, or the reconstruction's
// lowest point, or the hanging end's; the ladder's first rungs.
void Trial::PointFromKept(Step& s, const CandidateRegistration& reg, int v, const Registered& r) const {
  s.plan.predicted = s.plan.candidates[s.plan.kept].predicted;
  s.truth.ladder.rigid = r.to_world * reg.reg.rigid.V.row(v).transpose() + r.origin;
  s.truth.ladder.nonrigid = r.to_world * reg.final_mesh().V.row(v).transpose() + r.origin;
  // The turn is about the vertical: "below" is the same in the object frame.
  PointFromLowest(s, reg, v, r);
  if (!s.plan.lowest_taken) PointFromHangingEnd(s, reg, s.plan.candidates[s.plan.kept], r);
}

// Whether the candidate's target anchor (vertex `v` of its registered hang `hang`) or a
// symmetry twin of it is the hang's lowest point within `radius` horizontally: a twin's
// registration maps onto the garment's other side, and the plan accepts either (from a
// crotch or a waist both leg ends hang about as low, and either may be the lowest).
bool Trial::TargetIsLowest(const TriMesh& hang, int v, const CandidateTrace& c, double radius) const {
  const double tolerance = o_.plan.lowest.tolerance;
  if (AnchorIsLowest(hang, v, tolerance, radius)) return true;
  for (const std::string& twin : rec::SymmetryTwins(c.next_anchor)) {
    const int w = model_.AnchorVertex(c.candidate.instance, twin);
    if (w >= 0 && w < hang.NumVertices() && AnchorIsLowest(hang, w, tolerance, radius)) return true;
  }
  return false;
}

// The regrasp point from the reconstruction's lowest point (candidates.h LowestPoint): of
// the whole garment when the kept candidate's registered hang (rigid) has the target or
// its twin lowest, else the lowest near the registered target when the target or its
// twin is the lowest near itself (the search is around the target either way: around a
// registered twin it found waist corners on shorts held by the crotch).
void Trial::PointFromLowest(Step& s, const CandidateRegistration& reg, int v, const Registered& r) const {
  const LowestPointOptions& o = o_.plan.lowest;
  Planned& p = s.plan;
  const CandidateTrace& kept = p.candidates[p.kept];
  const double floor = model_.recipe().fusion.box.min().y();
  p.lowest_target = TargetIsLowest(reg.reg.rigid, v, kept, std::numeric_limits<double>::infinity());
  std::optional<Vec3> low;
  if (p.lowest_target) {
    low = LowestPoint(s.observe.recon, floor, o);
    if (!low)
      AddNote(s, "lowest point: the reconstruction's lowest point is the region's floor; registered point used");
  } else if (o.near_radius > 0) {
    p.lowest_near = TargetIsLowest(reg.reg.rigid, v, kept, o.near_radius);
    if (p.lowest_near) low = LowestPoint(s.observe.recon, floor, o, Vec3(reg.final_mesh().V.row(v).transpose()));
    if (p.lowest_near && !low)
      AddNote(s, "lowest point near the target: none above the region's floor; registered point used");
  }
  if (!low) return;
  p.predicted = r.to_world * *low + r.origin;
  p.lowest_taken = true;
}

// The regrasp point from the free end hanging below the target (candidates.h HangingEnd):
// the reconstruction's lowest point near the registered end, raised by the distance of
// target and end on the candidate instance's pattern. Only where the database hang (rigid
// registration) has the end below the target, as a free end hangs.
void Trial::PointFromHangingEnd(Step& s, const CandidateRegistration& reg, const CandidateTrace& c,
                                const Registered& r) const {
  const std::string end = HangingEnd(c.next_anchor);
  if (end.empty()) return;
  const std::string& instance = c.candidate.instance;
  const int v = model_.AnchorVertex(instance, c.next_anchor);
  const int e = model_.AnchorVertex(instance, end);
  const TriMesh& rigid = reg.reg.rigid;
  if (v < 0 || e < 0 || v >= rigid.NumVertices() || e >= rigid.NumVertices()) return;
  const std::optional<Vec2> uv_anchor = model_.AnchorUv(instance, c.next_anchor);
  const std::optional<Vec2> uv_end = model_.AnchorUv(instance, end);
  if (!uv_anchor || !uv_end) return;
  const double length = (*uv_anchor - *uv_end).norm();
  if (rigid.V(v, 1) - rigid.V(e, 1) < o_.plan.hanging.min_drop * length) return;  // the end is not below
  Planned& p = s.plan;
  p.hanging_end = end;
  p.hanging_length = length;
  const Vec3 around = reg.final_mesh().V.row(e).transpose();
  const auto low = LowestNear(s.observe.recon, around, model_.recipe().fusion.box.min().y(), o_.plan.hanging);
  if (!low) {
    AddNote(s, "hanging end: no reconstruction above the region's floor near the registered " + end +
                   "; registered point used");
    return;
  }
  p.predicted = r.to_world * (*low + Vec3(0, length, 0)) + r.origin;
  p.hanging_taken = true;
}

}  // namespace drape::unfolding
