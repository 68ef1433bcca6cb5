// The paper's folding evaluation in simulation (Table "garment_experiments_stat"):
// seeded trials that replay a plan's optimised trajectories on a perturbed scene —
// table friction ± 10 %, material jitter (stiffness and density ± 10 %), the garment
// placed a few centimetres off and turned a few degrees — each re-detecting the key
// points on its own flat garment (as the robot would) and mapping the trajectories to
// them. Success: the final shape's dissimilarity to the ideal chained folds below a
// fraction of the garment's size, AND its top-down silhouette inside the ideal one's.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "garments/garment.h"
#include "runtime/folding/run.h"

namespace drape::folding {

// Everything that makes a folding scene, before perturbation.
struct FoldSetup {
  Garment garment;         // flat, pattern frame (rest shape)
  ClothMaterial material;  // simulation material
  ClothOptions cloth;      // solver options
  double friction = 0.4;   // Coulomb μ on the table
  tabletop::TableOptions table;
  // How the garment lies when it does not start as its flat pattern (e.g. as `drape
  // unfold` placed it: placed.h), world frame of any table; empty = the pattern laid flat.
  Points3 lying;
};

// The garment on the setup's table, moved by `offset` (world x, z) and turned by `yaw`
// (radians): `lying` moved onto it (tabletop::PlaceOnTable), or the pattern laid flat (tabletop::LayFlat).
Points3 LaidGarment(const FoldSetup& setup, const Vec2& offset = Vec2::Zero(), double yaw = 0);

// scales multiply friction, link stiffness (capped at 1) and density.
FoldScene MakeScene(const FoldSetup& setup, double friction_scale = 1, double stiffness_scale = 1,
                    double density_scale = 1);

struct TrialOptions {
  int trials = 10;
  uint64_t seed = 1;
  double friction_jitter = 0.10;   // friction × U(1 − j, 1 + j)
  double material_jitter = 0.10;   // stiffness, density × U(1 − j, 1 + j)
  double placement_offset = 0.03;  // m, offset uniform in a disc of this radius
  double yaw_deg = 5;              // turned by U(−y, y) degrees
  // Success: D(ideal, final) ≤ d_fraction × the flat garment's diagonal (x–z), and at
  // least `inside` of the final top-down silhouette within the ideal silhouette grown
  // by `silhouette_tolerance`.
  double d_fraction = 0.05;
  double inside = 0.90;
  double silhouette_tolerance = 0.02;  // m
  void Validate() const;
};

struct TrialResult {
  int index = 0;
  bool success = false;
  bool completed = false;  // every plan step ran (else `failure` says what stopped it)
  std::string failure;     // what stopped the plan (key points, a simulation), or why the fold missed the criteria
  double friction_scale = 1, stiffness_scale = 1, density_scale = 1, yaw_deg = 0;
  Vec2 offset = Vec2::Zero();
  double final_dissimilarity = 0;  // m
  double diagonal = 0;             // m
  double inside_fraction = 0;
  double reach = 0;         // m, SilhouetteReach of the final shape at options.inside
  double sim_time = 0;      // s simulated (flat settle not counted)
  double wall_seconds = 0;  // timing only
  PlanRun run;              // for pictures
};

// Fraction of `shape`'s top-down silhouette inside `reference`'s grown by tolerance.
double SilhouetteInside(const TriMesh& shape, const TriMesh& reference, double tolerance, double metres_per_pixel);
// The distance (m) from `reference`'s top-down silhouette within which `fraction` of
// `shape`'s silhouette lies (0 when that much is inside it): how far the tolerance
// would have to grow for SilhouetteInside(…) ≥ fraction.
double SilhouetteReach(const TriMesh& shape, const TriMesh& reference, double fraction, double metres_per_pixel);

// Scores a completed run against the success criterion: fills diagonal,
// final_dissimilarity, inside_fraction, sim_time, success and failure from r.run.
void JudgeFold(TrialResult& r, const Faces& F, const TrialOptions& options);

// One trial. A failure inside it — key points not found on the perturbed garment, a
// plan that does not fit it (drape::Error), a simulation failure (NumericalError) —
// marks this trial failed with the reason and keeps what ran (r.run); it never throws
// for those.
TrialResult RunTrial(const FoldSetup& setup, const FoldingPlan& plan, const PlanRunOptions& run_options,
                     const std::vector<std::vector<RelativeTrajectory>>& trajectories, const TrialOptions& options,
                     int index);

// options.trials trials in order; `done` (if set) sees each as it finishes.
std::vector<TrialResult> RunTrials(const FoldSetup& setup, const FoldingPlan& plan, const PlanRunOptions& run_options,
                                   const std::vector<std::vector<RelativeTrajectory>>& trajectories,
                                   const TrialOptions& options,
                                   const std::function<void(const TrialResult&)>& done = {});

}  // namespace drape::folding
