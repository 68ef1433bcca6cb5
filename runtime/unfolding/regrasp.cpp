// The regrasp phase (trial.h): the free gripper faces the predicted point from outside,
// scans across it with its IR range sensor (refine.h: the LoG of the height signal), and
// closes there; then both keep hold (f ≥ ξ on a holder an aimed regrasp placed) or the
// old gripper lets go and the garment falls to hang from the new grasp.
#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/field_error.h"
#include "common/timing.h"
#include "runtime/unfolding/trial.h"

namespace drape::unfolding {

namespace hw = drape::hardware;

void RegraspOptions::Validate() const {
  refine.Validate();
  if (!(standoff > 0 && standoff < 0.4)) BadField(standoff, "RegraspOptions.standoff", "must be in (0, 0.4) m");
  if (!(grasp_depth >= 0 && grasp_depth < 0.1))
    BadField(grasp_depth, "RegraspOptions.grasp_depth", "must be in [0, 0.1) m");
}

bool MayStop(const ObjectiveOptions& o, double f, bool holder_regrasped) { return f >= o.xi && holder_regrasped; }

namespace {
// One IR scan by the free gripper: the jaws (in the grasp pose `pose`) go to jaw(0) along
// a straight path, then to jaw(1), ..., jaw(n - 1) in short moves, one reading at each.
std::vector<double> ScanIr(hw::Arm& arm, hw::RangeSensor& ir, hw::GripperPose pose, int n,
                           const std::function<Vec3(int)>& jaw) {
  std::vector<double> ranges;
  for (int i = 0; i < n; ++i) {
    pose.position = jaw(i);
    arm.Move(i == 0 ? hw::StraightPath(arm.pose(), pose) : hw::Path{{0.016, pose}});
    ranges.push_back(ir.Read());
  }
  return ranges;
}
}  // namespace

// The IR scan and the grasp: false on a miss (the free arm opens and goes home).
bool Trial::Regrasp(Step& s, int free_arm) {
  hw::Arm& fa = world_.arm(free_arm);
  const hw::GripperPose g = Refine(s, free_arm);
  MeasureAgainstTruth(s);
  fa.Move(hw::StraightPath(fa.pose(), g));
  MeasureClosing(s, g);
  s.regrasp.report = fa.Close();
  ++res_.regrasps;
  if (s.regrasp.report.outcome == hw::GraspOutcome::kMiss) {
    fa.Open();
    fa.Move(hw::StraightPath(fa.pose(), Home(free_arm)));
    return false;
  }
  s.truth.regrasp_uv = world_.HeldUv(free_arm);
  s.truth.regrasp_anchor = NearestAnchor(world_.garment(), *s.truth.regrasp_uv);
  if (const Anchor* t = world_.garment().FindAnchor(s.truth.target_anchor))
    s.truth.regrasp_pattern_error = (*s.truth.regrasp_uv - t->uv).norm();
  s.regrasp.holder_regrasped = holder_regrasped_;
  return true;
}

// The IR scan across the predicted point with the free gripper; returns the grasp pose.
hw::GripperPose Trial::Refine(Step& s, int free_arm) {
  const auto t0 = Clock::now();
  const RegraspOptions& o = o_.regrasp;
  const Vec3& predicted = s.plan.predicted;
  const Vec3 axis = world_.arm(holder_).pose().position;
  Vec3 radial(predicted.x() - axis.x(), 0, predicted.z() - axis.z());
  if (radial.norm() < 0.02) radial = Vec3(0, 0, 1);  // on the axis: come from the camera's side
  const Vec3 a = -radial.normalized();
  const Vec3 c = Vec3::UnitY().cross(a).normalized();
  s.regrasp.approach = a;
  hw::GripperPose g;
  g.approach = a;
  g.closing = c;
  g.position = predicted + a * o.grasp_depth;
  if (o.ir_refinement) {
    hw::Arm& arm = world_.arm(free_arm);
    hw::RangeSensor& ir = world_.ir(free_arm);
    IrScanPlan plan;
    plan.predicted = predicted;
    plan.approach = a;
    plan.closing = c;
    plan.mount = ir.mount();
    plan.standoff = o.standoff;
    plan.grasp_depth = o.grasp_depth;
    const int half = o.refine.half_width_samples;
    s.regrasp.ir_ranges = ScanIr(arm, ir, g, 2 * half + 1,
                                 [&](int i) { return plan.JawDuringScan((i - half) * o.refine.sample_spacing); });
    RefineOptions ro = o.refine;
    // An observed point (the lowest point, a hanging end): the scan gives the depth only.
    if (s.plan.lowest_taken || s.plan.hanging_taken) ro.search_half_width_samples = 0;
    if (s.plan.hanging_taken) {
      ro.depth_half_width_samples = std::min(
          ro.half_width_samples, static_cast<int>(std::lround(o_.plan.hanging.depth_window / ro.sample_spacing)));
    }
    s.regrasp.refine = RefineScan(s.regrasp.ir_ranges, ro);
    if (s.regrasp.refine.valid) {
      g.position = plan.Grasp(s.regrasp.refine);
    } else {
      AddNote(s, "no IR reading in the whole scan: registered point used");
    }
  }
  res_.times.refinement += Since(t0);
  s.regrasp.grasp = g.position;
  return g;
}

// Not there yet: the old grasp lets go and goes home, the garment falls to hang from the
// new one, which carries it to the sensing pose.
void Trial::LetGo(Step& s, int free_arm) {
  hw::Arm& old = world_.arm(holder_);
  old.Open();
  s.regrasp.released_other = true;
  old.Move(hw::StraightPath(old.pose(), Home(holder_)));
  hw::Arm& fa = world_.arm(free_arm);
  fa.Move(hw::StraightPath(fa.pose(), SensingPose(o_.observe.sensing_height)));
  holder_ = free_arm;
  holder_regrasped_ = true;
}

}  // namespace drape::unfolding
