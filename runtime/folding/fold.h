// One folding step with the cloth simulation in the loop (paper §"Folding Pipeline in
// Simulation", §"Trajectory Optimization"): grippers close on the cloth at the grasp
// points, carry it along cubic Bézier trajectories, release it at the targets and the
// cloth settles on the table; the step's cost is C(x) = l_x + α·D(S_t, S_x), and
// OptimiseStep minimises C² over the knot points P1, P2 of every arm (stacked into one
// state for two arms) by the shared secant Levenberg–Marquardt with forward
// differences, δ = 0.1 m.
//
// Gripper models (the paper's sim/real gap: "moving a point on the mesh in the
// simulation is different from using a gripper to grasp a small area"):
//   kPinch — a parallel-jaw gripper closing vertically through the cloth (8 cm opening,
//            3 × 3 cm pads): it holds every node of every layer in that small area;
//   kPoint — holds the single nearest top-layer vertex (the paper's simulation).
// The grasp point follows the Bézier at constant speed; the held nodes follow rigidly,
// turning by π about the fold line along the way (turn_with_fold), so at P3 they lie
// exactly where the ideal fold puts them.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "generator/cloth/world.h"
#include "runtime/folding/bezier.h"
#include "runtime/folding/gripper.h"
#include "runtime/folding/target.h"
#include "runtime/optim/secant_lm.h"

namespace drape::folding {

// The garment on its table: immutable, shared by every simulation of a run.
struct FoldScene {
  std::shared_ptr<const ClothModel> model;
  BoxCollider table;
  double table_top = 0;  // m, world y of the table's top face
};

struct FoldSimOptions {
  GripperModel gripper = GripperModel::kPinch;
  Jaw jaw;                     // kPinch: 8 cm opening across the layers, 3 × 3 cm pads
  double speed = 0.4;          // m/s of the grasp point along the Bézier
  double hold_time = 0.1;      // s held still at P3 before the grippers open
  bool turn_with_fold = true;  // held cloth turns by π about the fold line on the way
  int path_keys = 32;          // gripper poses per trajectory (linear in between)
  // After release: settled when no node moves more than 2 mm over 0.2 s; a step that
  // is still creeping at the cap is scored as it is (StepSim::settled = false).
  SettleOptions settle = {0.002, 0.2, 0.3, 3.0};
  // Path points are kept this far above the table top (a robot cannot go through it).
  double min_clearance = 0.004;  // m
  void Validate() const;
};

// What a step starts from: the settled state, the ideal fold and target, the grasps.
struct StepSetup {
  Points3 start;                    // positions entering the step (settled)
  std::vector<int> grasp_vertices;  // the cloth points grasped, one per arm
  std::vector<Vec3> p0, p3;         // each grasp point's start and target
  std::shared_ptr<IdealFold> fold;
  TriMesh target;  // S_t
};

// `grasp_vertices`: the cloth points (vertices) the arms take; the fold line is fixed on
// the table. thickness: the ideal fold's lift (the collision thickness).
StepSetup PrepareStep(const FoldScene& scene, const Points3& start, const FoldLine& line,
                      const std::vector<int>& grasp_vertices, double thickness);

struct StepSim {
  bool ok = false;
  std::string failure;  // why not ok (a miss, a blow-up)
  Points3 final;        // positions after release and settling
  bool settled = false;
  std::vector<int> held;     // nodes held per gripper
  double length = 0;         // l_x, m (sum over arms)
  double dissimilarity = 0;  // D(S_t, S_x), m
  double cost = 0;           // C = l_x + α·D
  double sim_time = 0;       // s simulated
  int steps = 0;
  double time_step = 0;         // s: the model's, or half of it after a blow-up
  double wall_seconds = 0;      // timing only
  std::vector<Points3> frames;  // key frames when asked: path at 0, ⅓, ⅔, 1, after settling
};

// The arms' trajectories must start at setup.p0 and end at setup.p3. A simulation that
// blows up is run once more at half the time step (as a hang is; damping per second
// kept), and fails only if that blows up too.
StepSim SimulateStep(const FoldScene& scene, const StepSetup& setup, const std::vector<CubicBezier>& paths,
                     const FoldSimOptions& options, double alpha = 1e3, bool keep_frames = false);

struct OptimiseOptions {
  double alpha = 1e3;              // paper's α
  double h = 1.0 / 3;              // paper's initial knot height factor
  double length_tolerance = 1e-4;  // relative, De Casteljau length
  optim::SecantLmOptions lm = DefaultLm();
  // δ = 0.1 m, ≤ 40 simulations, stop on < 1 % gains, steps ≤ 0.1 m (trust radius).
  static optim::SecantLmOptions DefaultLm();
  void Validate() const;
};

struct StepOptimum {
  std::vector<CubicBezier> initial, optimised;
  StepSim before, after;  // simulations of the initial and optimised trajectories
  optim::SecantLmReport lm;
  int simulations = 0;            // inside the optimiser (before/after not counted)
  std::vector<double> evaluated;  // C of each of those simulations in order (NaN = failed)
  double wall_seconds = 0;
};

// Knot points ↔ state vector: per arm (P1, P2), 6 numbers per arm, metres.
Eigen::VectorXd StackKnots(const std::vector<CubicBezier>& paths);
std::vector<CubicBezier> UnstackKnots(const Eigen::VectorXd& x, const std::vector<Vec3>& p0,
                                      const std::vector<Vec3>& p3);
// Σ_arms De Casteljau length.
double PathLength(const std::vector<CubicBezier>& paths, double tolerance);

// From the paper's initial trajectories (h along e_v) to the optimised ones.
StepOptimum OptimiseStep(const FoldScene& scene, const StepSetup& setup, const FoldSimOptions& sim,
                         const OptimiseOptions& options);

}  // namespace drape::folding
