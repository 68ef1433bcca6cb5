// A step measured against the simulated garment (trial.h; evaluation only: the loop never
// decides on it): each prediction's distance to the real target anchor as the cloth hangs,
// and the regrasp point's error ladder (step.h StepTruth::Ladder).
#include <limits>

#include "runtime/recognition/evaluate.h"
#include "runtime/unfolding/trial.h"

namespace drape::unfolding {

namespace rec = drape::recognition;
namespace hw = drape::hardware;

namespace {
// `anchor` and its symmetry twins, the anchor first.
std::vector<std::string> WithTwins(const std::string& anchor) {
  std::vector<std::string> labels = rec::SymmetryTwins(anchor);
  labels.insert(labels.begin(), anchor);
  return labels;
}
}  // namespace

void Trial::MeasureAgainstTruth(Step& s) const {
  const Garment& g = world_.garment();
  const TriMesh& cloth = world_.mesh();
  auto vertex = [&](const std::string& label) -> const Anchor* {
    const Anchor* a = g.FindAnchor(label);
    return a && a->vertex >= 0 && a->vertex < cloth.NumVertices() ? a : nullptr;
  };
  // Each candidate's prediction against its own next anchor (or a twin, nearer).
  for (CandidateTrace& t : s.plan.candidates) {
    if (!t.usable) continue;
    for (const std::string& l : WithTwins(t.next_anchor)) {
      const Anchor* a = vertex(l);
      if (!a) continue;
      const double d = (t.predicted - Vec3(cloth.V.row(a->vertex))).norm();
      if (t.truth.predicted_error < 0 || d < t.truth.predicted_error) t.truth.predicted_error = d;
    }
  }
  StepTruth& T = s.truth;
  const Vec3& predicted = s.plan.predicted;
  double best = std::numeric_limits<double>::infinity();
  Vec3 target = Vec3::Zero();
  for (const std::string& l : WithTwins(s.plan.next_anchor)) {
    const Anchor* a = vertex(l);
    if (!a) continue;
    const Vec3 p = cloth.V.row(a->vertex);
    if ((predicted - p).norm() < best) {
      best = (predicted - p).norm();
      T.target_anchor = l;
      T.predicted_error = best;
      T.grasp_error = (s.regrasp.grasp - p).norm();
      target = p;
    }
  }
  if (T.target_anchor.empty()) return;
  StepTruth::Ladder& L = T.ladder;
  L.rigid_error = (L.rigid - target).norm();
  L.nonrigid_error = (L.nonrigid - target).norm();
  L.mapped_error = T.predicted_error;
  L.refined_error = T.grasp_error;
  const Vec3& approach = s.regrasp.approach;
  const Vec3 c = Vec3::UnitY().cross(approach).normalized();
  auto frame = [&](const Vec3& d) { return Vec3(d.dot(c), d.y(), d.dot(approach)); };
  L.mapped_offset = frame(predicted - target);
  L.refined_offset = frame(s.regrasp.grasp - target);
  // What the jaws would take at the registered point without the IR scan.
  hw::GripperPose at;
  at.approach = approach;
  at.closing = c;
  at.position = predicted + approach * o_.regrasp.grasp_depth;
  const hw::GraspProbe p = world_.ProbeGrasp(at);
  L.no_ir_outcome = hw::GraspOutcomeName(p.report.outcome);
  const Anchor* ta = g.FindAnchor(T.target_anchor);
  if (p.uv) {
    L.no_ir_pinch_error = (p.pinch - target).norm();
    if (ta) L.no_ir_pattern_error = (*p.uv - ta->uv).norm();
  }
}

// Rung (e) of the ladder: where the jaws at `g` close (probed just before they do).
void Trial::MeasureClosing(Step& s, const hw::GripperPose& g) const {
  if (s.truth.target_anchor.empty()) return;
  const Anchor* a = world_.garment().FindAnchor(s.truth.target_anchor);
  if (!a || a->vertex < 0 || a->vertex >= world_.mesh().NumVertices()) return;
  const Vec3 target = world_.mesh().V.row(a->vertex);
  const hw::GraspProbe p = world_.ProbeGrasp(g);
  if (!p.uv) return;
  StepTruth::Ladder& L = s.truth.ladder;
  L.closed = p.centroid;
  L.pinch = p.pinch;
  L.closed_error = (p.centroid - target).norm();
  L.pinch_error = (p.pinch - target).norm();
}

}  // namespace drape::unfolding
