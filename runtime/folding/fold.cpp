#include "runtime/folding/fold.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "common/format.h"
#include "common/timing.h"
#include "runtime/folding/dissimilarity.h"

namespace drape::folding {
namespace {

// Gripper frame → world at rest: closing axis (gripper x) vertical, so the jaw closes
// across every layer lying on the table; fingers along world z, pads across world x.
Eigen::Matrix3d PinchBase() {
  Eigen::Matrix3d r;
  r << 0, 0, 1,  //
      1, 0, 0,   //
      0, 1, 0;   // columns: gripper x → world y, y → world z, z → world x
  return r;
}

// The jaw centre relative to the grasp point, and the jaw itself, per model: the pinch
// jaw's lower half reaches just below the table top so it takes the whole stack; the
// point jaw is 2 mm across, about one vertex.
struct Grip {
  Jaw jaw;
  Vec3 offset = Vec3::Zero();  // jaw centre − grasp point, world, at the start
};

Grip MakeGrip(const FoldScene& scene, const FoldSimOptions& o, const Vec3& p0) {
  Grip g;
  if (o.gripper == GripperModel::kPinch) {
    g.jaw = o.jaw;
    const double centre_y = scene.table_top + o.jaw.opening / 2 - 0.001;
    g.offset = Vec3(0, centre_y - p0.y(), 0);
  } else {
    g.jaw.opening = g.jaw.pad_length = g.jaw.pad_width = 0.002;
  }
  return g;
}

}  // namespace

void FoldSimOptions::Validate() const {
  jaw.Validate();
  settle.Validate();
  if (!(speed > 0 && speed < 10)) throw Error("FoldSimOptions.speed must be in (0, 10) m/s");
  if (!(hold_time >= 0)) throw Error("FoldSimOptions.hold_time must be >= 0 s");
  if (path_keys < 2) throw Error("FoldSimOptions.path_keys must be >= 2");
  if (!(min_clearance >= 0)) throw Error("FoldSimOptions.min_clearance must be >= 0 m");
}

StepSetup PrepareStep(const FoldScene& scene, const Points3& start, const FoldLine& line,
                      const std::vector<int>& grasp_vertices, double thickness) {
  if (grasp_vertices.empty() || grasp_vertices.size() > 2) throw Error("fold step: one or two grasp points");
  StepSetup s;
  s.start = start;
  s.grasp_vertices = grasp_vertices;
  for (int v : grasp_vertices) {
    if (v < 0 || v >= start.rows()) throw Error("fold step: grasp vertex out of range");
    s.p0.push_back(start.row(v).transpose());
  }
  s.fold = std::make_shared<IdealFold>(line, Vec2(s.p0[0].x(), s.p0[0].z()), start, thickness,
                                       LongestEdge(scene.model->rest));
  for (const Vec3& p : s.p0) {
    if (!s.fold->Folds(p)) throw Error("fold step: the grasp points lie on different sides of the fold line");
    s.p3.push_back(s.fold->Apply(p));
  }
  s.target = TargetShape(TriMesh{start, scene.model->rest.F}, *s.fold);
  return s;
}

double PathLength(const std::vector<CubicBezier>& paths, double tolerance) {
  double l = 0;
  for (const auto& c : paths) l += BezierLength(c, tolerance).length;
  return l;
}

namespace {

StepSim SimulateOnce(const FoldScene& scene, const StepSetup& setup, const std::vector<CubicBezier>& paths,
                     const FoldSimOptions& o, double alpha, bool keep_frames) {
  const auto t_start = Clock::now();
  const size_t arms = setup.p0.size();
  DRAPE_CHECK(paths.size() == arms, "one path per arm");
  StepSim r;
  r.length = PathLength(paths, 1e-4);
  ClothWorld w(scene.model, setup.start);
  w.AddCollider(scene.table);
  const double dt = scene.model->options.time_step;
  // Every arm takes the same time (they arrive together), each at constant speed.
  const double duration = std::max(0.2, r.length / arms / o.speed);
  const double floor = scene.table_top + o.min_clearance;
  for (size_t a = 0; a < arms; ++a) {
    const Grip grip = MakeGrip(scene, o, setup.p0[a]);
    Eigen::Isometry3d pose0 = Eigen::Isometry3d::Identity();
    pose0.linear() = PinchBase();
    pose0.translation() = setup.p0[a] + grip.offset;
    const int g = w.AddGripper(grip.jaw, pose0);
    const GraspReport rep = w.Close(g);
    if (rep.miss) {
      r.failure = "gripper " + std::to_string(a) + " caught no cloth at the grasp point";
      r.cost = std::numeric_limits<double>::quiet_NaN();
      return r;
    }
    r.held.push_back(rep.nodes);
    // Poses along the path: the grasp point at constant speed, the jaw turning about
    // the fold line's direction with the fold (rigidly about the grasp point).
    const auto pts = SampleByArcLength(paths[a], o.path_keys);
    GripperPath path;
    for (int k = 0; k <= o.path_keys; ++k) {
      const double f = static_cast<double>(k) / o.path_keys;
      const Eigen::Matrix3d R = o.turn_with_fold ? setup.fold->Rotation(f) : Eigen::Matrix3d::Identity();
      Vec3 p = pts[k];
      p.y() = std::max(p.y(), floor);
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.linear() = R * PinchBase();
      pose.translation() = p + R * grip.offset;
      path.times.push_back(f * duration);
      path.poses.push_back(pose);
    }
    w.SetPath(g, path);
  }
  const int move_steps = static_cast<int>(std::ceil((duration + o.hold_time) / dt));
  const int frame_every = std::max(1, static_cast<int>(std::lround(duration / dt / 3)));
  for (int s = 0; s < move_steps; ++s) {
    if (keep_frames && s % frame_every == 0 && r.frames.size() < 3) r.frames.push_back(w.positions());
    w.Step();
    if (s % 24 == 0) {
      const std::string health = w.Health();
      if (!health.empty()) {
        r.failure = "while folding: " + health;
        r.cost = std::numeric_limits<double>::quiet_NaN();
        return r;
      }
    }
  }
  if (keep_frames) r.frames.push_back(w.positions());
  for (int g = 0; g < w.NumGrippers(); ++g) w.Open(g);
  const SettleReport settle = w.Settle(o.settle);
  if (!settle.settled && !settle.timed_out) {
    r.failure = "after release: " + settle.failure;
    r.cost = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  r.settled = settle.settled;
  r.final = w.positions();
  if (keep_frames) r.frames.push_back(r.final);
  r.steps = move_steps + settle.steps;
  r.sim_time = w.time();
  r.dissimilarity = Dissimilarity(setup.target, TriMesh{r.final, scene.model->rest.F});
  r.cost = FoldCost(r.length, r.dissimilarity, alpha);
  r.ok = true;
  r.wall_seconds = Since(t_start);
  return r;
}

// The same cloth at half the time step, with the same damping per simulated second.
std::shared_ptr<const ClothModel> HalfStep(const ClothModel& m) {
  ClothOptions o = m.options;
  o.time_step /= 2;
  o.damping = 1 - std::sqrt(1 - o.damping);
  return MakeClothModel(m.rest, m.layer, m.material, o);
}

}  // namespace

StepSim SimulateStep(const FoldScene& scene, const StepSetup& setup, const std::vector<CubicBezier>& paths,
                     const FoldSimOptions& o, double alpha, bool keep_frames) {
  o.Validate();
  StepSim r = SimulateOnce(scene, setup, paths, o, alpha, keep_frames);
  r.time_step = scene.model->options.time_step;
  if (r.ok || r.failure.find("blew up") == std::string::npos) return r;
  FoldScene fine = scene;
  fine.model = HalfStep(*scene.model);
  const double wall = r.wall_seconds;
  r = SimulateOnce(fine, setup, paths, o, alpha, keep_frames);
  r.time_step = fine.model->options.time_step;
  r.wall_seconds += wall;
  if (!r.ok) r.failure += " (after a retry at time_step " + FormatFixed(1e3 * r.time_step, 3) + " ms)";
  return r;
}

optim::SecantLmOptions OptimiseOptions::DefaultLm() {
  optim::SecantLmOptions lm;
  lm.finite_difference_step = 0.1;  // paper's δ, metres
  lm.max_iterations = 20;
  lm.max_residual_evaluations = 40;  // simulations per step
  lm.step_tolerance = 1e-3;          // relative to ‖x‖ (~0.3–1 m): sub-millimetre steps
  lm.relative_decrease = 0.01;       // "improvement in C² sufficiently small": < 1 % ...
  lm.stall_iterations = 2;           // ... twice in a row
  lm.tau = 1e-3;
  // Trust radius = δ: B is a secant over δ, and the one-residual Gauss-Newton step
  // (length C/‖∇C‖, aiming at C = 0, which no fold reaches) was 0.2–0.5 m on the towel.
  lm.max_step = 0.1;
  return lm;
}

void OptimiseOptions::Validate() const {
  if (!(alpha >= 0)) throw Error("OptimiseOptions.alpha must be >= 0");
  if (!(h >= 0 && h < 5)) throw Error("OptimiseOptions.h must be in [0, 5)");
  if (!(length_tolerance > 0)) throw Error("OptimiseOptions.length_tolerance must be > 0");
  lm.Validate();
  if (!(lm.finite_difference_step > 0)) throw Error("OptimiseOptions.lm.finite_difference_step must be > 0");
}

Eigen::VectorXd StackKnots(const std::vector<CubicBezier>& paths) {
  Eigen::VectorXd x(6 * paths.size());
  for (size_t a = 0; a < paths.size(); ++a)
    x.segment<3>(6 * a) = paths[a].P[1], x.segment<3>(6 * a + 3) = paths[a].P[2];
  return x;
}

std::vector<CubicBezier> UnstackKnots(const Eigen::VectorXd& x, const std::vector<Vec3>& p0,
                                      const std::vector<Vec3>& p3) {
  DRAPE_CHECK(x.size() == static_cast<Eigen::Index>(6 * p0.size()) && p0.size() == p3.size(), "knot vector size");
  std::vector<CubicBezier> out;
  for (size_t a = 0; a < p0.size(); ++a)
    out.push_back(CubicBezier{{p0[a], x.segment<3>(6 * a), x.segment<3>(6 * a + 3), p3[a]}});
  return out;
}

namespace {
// r(x) = C(x): one residual, a cloth simulation per evaluation; a failed simulation
// gives NaN (the optimiser rejects that step).
class FoldCostProblem : public optim::LeastSquaresProblem {
 public:
  FoldCostProblem(const FoldScene& scene, const StepSetup& setup, const FoldSimOptions& sim, const OptimiseOptions& o,
                  std::vector<double>* trace)
      : scene_(scene), setup_(setup), sim_(sim), o_(o), trace_(trace) {}
  int NumResiduals() const override { return 1; }
  int NumParameters() const override { return static_cast<int>(6 * setup_.p0.size()); }
  void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override {
    const StepSim s = SimulateStep(scene_, setup_, UnstackKnots(x, setup_.p0, setup_.p3), sim_, o_.alpha);
    r.resize(1);
    r[0] = s.ok ? s.cost : std::numeric_limits<double>::quiet_NaN();
    trace_->push_back(r[0]);
    if (s.ok && s.cost < best_cost) best_cost = s.cost, best_x = x;
  }
  // The best point simulated (steps and difference probes alike): every evaluation is
  // an exact, deterministic C, so a probe better than the optimiser's end point is kept.
  mutable double best_cost = std::numeric_limits<double>::infinity();
  mutable Eigen::VectorXd best_x;

 private:
  const FoldScene& scene_;
  const StepSetup& setup_;
  const FoldSimOptions& sim_;
  const OptimiseOptions& o_;
  std::vector<double>* trace_;
};
}  // namespace

StepOptimum OptimiseStep(const FoldScene& scene, const StepSetup& setup, const FoldSimOptions& sim,
                         const OptimiseOptions& o) {
  o.Validate();
  const auto t0 = Clock::now();
  StepOptimum out;
  for (size_t a = 0; a < setup.p0.size(); ++a) out.initial.push_back(InitialTrajectory(setup.p0[a], setup.p3[a], o.h));
  out.before = SimulateStep(scene, setup, out.initial, sim, o.alpha, true);
  if (!out.before.ok) throw NumericalError("fold: the initial trajectory failed: " + out.before.failure);
  Eigen::VectorXd x = StackKnots(out.initial);
  if (o.lm.max_iterations == 0) {  // keep h = 1/3 (no B0 by differences either)
    out.optimised = out.initial;
    out.after = out.before;
    out.wall_seconds = Since(t0);
    return out;
  }
  const FoldCostProblem problem(scene, setup, sim, o, &out.evaluated);
  out.lm = optim::SolveSecantLm(problem, x, o.lm);
  out.simulations = out.lm.residual_evaluations;
  if (problem.best_cost < std::sqrt(2 * out.lm.final_cost)) x = problem.best_x;
  out.optimised = UnstackKnots(x, setup.p0, setup.p3);
  out.after = SimulateStep(scene, setup, out.optimised, sim, o.alpha, true);
  out.wall_seconds = Since(t0);
  return out;
}

}  // namespace drape::folding
