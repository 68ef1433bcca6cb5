// A whole folding plan in simulation: the flat garment settles on the table, the
// camera above it finds the key points, each plan step is prepared from the state the
// previous one left (fold line fixed on the table, grasp points tracked as cloth
// points), simulated with the paper's initial trajectories, optimised, and the
// optimised step's result starts the next step (paper: "similar steps are repeated
// until the garment is folded in the simulator"). A replay runs stored trajectories
// (relative to each step's P0 → P3, so they carry over to a garment placed elsewhere)
// without optimising: the evaluation trials.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "runtime/folding/fold.h"
#include "runtime/folding/keypoints.h"
#include "runtime/folding/plan.h"
#include "runtime/tabletop/table.h"

namespace drape::folding {

// A knot point in the frame of its step: (P − P0) in units of s = ‖P3 − P0‖ along
// u = horizontal direction P0 → P3, v = up, w = u × v. The paper's initial knots are
// (⅓, h, 0) and (⅔, h, 0).
struct RelativeTrajectory {
  Vec3 k1 = Vec3::Zero(), k2 = Vec3::Zero();
  // The absolute path the knots were taken from (ToRelative, or a replay file's
  // "optimised"), if known. FromRelative returns it as it was when P0 and P3 are its own,
  // bit for bit: the frame's round trip is exact only to ~1e-16 m, and a fold's cloth
  // grows that into millimetres, so an unperturbed replay would not reproduce its run.
  std::optional<CubicBezier> source;
};
RelativeTrajectory ToRelative(const CubicBezier& c);
CubicBezier FromRelative(const RelativeTrajectory& r, const Vec3& p0, const Vec3& p3);

struct StepRecord;

struct PlanRunOptions {
  FoldSimOptions sim;  // sim.gripper: the default for plan steps that do not name theirs
  OptimiseOptions optimise;
  KeyPointOptions key_points;
  double camera_metres_per_pixel = 0.003;
  double thickness = 0.004;                            // m, ideal fold's lift (the cloth world's collision thickness)
  SettleOptions flat_settle = {0.002, 0.2, 0.3, 3.0};  // the garment laid on the table
  // Told each step as it finishes (a long optimisation reports as it goes); optional.
  std::function<void(const StepRecord&)> on_step;
  void Validate() const;
};

struct StepRecord {
  std::string name;
  FoldLine line;                                // world x, z
  std::vector<std::string> grasps;              // what the plan names, per arm
  GripperModel gripper = GripperModel::kPinch;  // the plan step's, else the run's default
  StepSetup setup;
  StepOptimum result;                        // replays: initial = optimised = the replayed paths
  std::vector<RelativeTrajectory> relative;  // of result.optimised
};

struct PlanRun {
  Points3 flat;                            // settled flat garment
  std::map<std::string, Vec2> key_points;  // world x, z
  tabletop::TopDownCamera camera;
  std::vector<StepRecord> steps;
  Points3 final;                   // after the last step
  TriMesh ideal;                   // the ideal folds chained from `flat`
  double final_dissimilarity = 0;  // D(ideal, final), m
};

// What a plan asks of a garment, before any simulation: per step the fold line (world
// x, z, fixed on the table), the cloth points grasped (vertices of the flat garment's
// top layer) and the ideal shape after it (the ideal folds chained from the flat one).
struct PlannedStep {
  std::string name;
  FoldLine line;
  std::vector<int> grasp_vertices;  // one per arm
  std::vector<std::string> grasps;  // what the plan names, per arm
  TriMesh ideal;                    // the flat garment after the ideal folds up to this one
};
// `key_points`: world x, z (the camera's key points of `flat`). Throws drape::Error
// naming the plan file, line and step for a plan that does not fit (a grasp point on
// its fold line, a degenerate line).
std::vector<PlannedStep> PlanSteps(const TriMesh& flat, const std::map<std::string, Vec2>& key_points,
                                   const FoldingPlan& plan, double thickness);

// Optimises every step (replay == nullptr) or replays the given relative trajectories
// (one vector per step, one per arm). Throws drape::Error for a plan that does not fit
// the garment, NumericalError when a simulation fails.
PlanRun RunPlan(const FoldScene& scene, const Points3& laid, const std::string& category, const FoldingPlan& plan,
                const PlanRunOptions& options, const std::vector<std::vector<RelativeTrajectory>>* replay = nullptr);
// The same, filling `run` as it goes (the settled flat garment, its camera and key
// points, each finished step), so a caller that catches a failure keeps what was done.
void RunPlan(PlanRun& run, const FoldScene& scene, const Points3& laid, const std::string& category,
             const FoldingPlan& plan, const PlanRunOptions& options,
             const std::vector<std::vector<RelativeTrajectory>>* replay = nullptr);

// Settles a garment laid on the table (no grippers). Throws NumericalError on a blow-up.
Points3 SettleFlat(const FoldScene& scene, const Points3& laid, const SettleOptions& settle);

}  // namespace drape::folding
