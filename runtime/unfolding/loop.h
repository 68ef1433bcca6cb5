// The paper's Algorithm "Iterative Procedure for Regrasping" on (simulated) hardware:
//
//   pick up at a random point with one gripper;
//   repeat: turn the garment in front of the Kinect → fuse (TSDF) → feature → recognise
//     the grasped anchor (learned weights) → register the matched database mesh to the
//     reconstruction (scale + ICP + non-rigid) → f over anchor pairs: the best next
//     anchor j* for the recognised current one → map j* through the registration onto
//     the reconstruction → IR scan across it, LoG minimum (local refinement) → the free
//     gripper takes it; if f(current, j*) ≥ ξ keep both (done), else the other gripper
//     lets go and the garment hangs from the new grasp;
//   until f ≥ ξ or max_regrasps regrasps.
//
// Every decision uses only what the robot senses (sweeps, IR readings, tactile checks)
// and the database; the simulation's ground truth (which point of the pattern each
// gripper pinches) is recorded beside it for evaluation.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "common/json.h"
#include "garments/garment.h"
#include "runtime/hardware/sim.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/unfolding/objective.h"
#include "runtime/unfolding/release_model.h"
#include "runtime/unfolding/step.h"

namespace drape::unfolding {

struct LoopOptions {
  int max_regrasps = 4;  // regrasp attempts before giving up
  ObserveOptions observe;
  RecogniseOptions recognise;
  PlanOptions plan;
  RegraspOptions regrasp;
  // Declare f ≥ ξ only when the hang just sensed supports the belief (Trial::Verify: the
  // held anchor among recognition's top k at its own hang, and that hang's category by
  // registration the trial's); else the holder lets go and the loop goes on. false: declare
  // on the belief, as the paper's loop (an ablation).
  bool verify = true;
  bool place_flat = true;  // lay the garment on the table when f ≥ ξ (cloth core)
  hardware::PlaceFlatOptions place;
  // Evaluation only: unfolded when each gripper pinches within this distance (m, on the
  // flat pattern) of a desired pair's anchors.
  double success_distance = 0.06;
  void Validate() const;  // throws drape::Error naming the bad field
};

// Seconds of one trial by stage (wall clock; timing only).
struct StageTimes {
  double simulation = 0, sensing = 0, fusion = 0, recognition = 0, registration = 0, refinement = 0;
  Json ToJson() const;
};

struct TrialResult {
  std::string category, instance;
  uint64_t seed = 0;
  double sensing_height = 0;  // m: where the holding gripper turned the garment
  Vec2 first_grasp_uv = Vec2::Zero();
  std::vector<Step> steps;
  int regrasps = 0;                  // regrasp attempts made
  bool recognition_success = false;  // first recognition right
  bool regrasp_success = false;      // every regrasp attempt pinched cloth
  bool converged = false;            // f ≥ ξ reached
  bool unfolded = false;             // truth: both grippers within success_distance of a desired pair
  double final_f = 0;
  std::vector<Vec2> final_uv;  // truth: pinched points at the end
  // Truth: how far the two pinched points are from a desired pair (DesiredPairDistance,
  // m on the pattern); -1 unless both grippers hold. Unfolded = converged and ≤ success_distance.
  double final_pair_distance = -1;
  // The first step that reached f ≥ ξ on a holder an aimed regrasp placed: where a loop
  // declaring on the belief alone (LoopOptions::verify false) would have stopped, its
  // regrasps then and its truth (DesiredPairDistance there, m); -1 if none reached it.
  int belief_step = -1, belief_regrasps = 0;
  double belief_pair_distance = -1;
  bool belief_unfolded = false;  // belief_pair_distance within success_distance
  int rejected = 0;              // stops the verification held back
  std::string failure;           // why the trial ended early ("" if it ran to the end)
  std::string final_state;
  TriMesh final_mesh;  // world frame (laid on the table when placed)
  // Placing flat (cloth core) once f ≥ ξ: coverage = top-down silhouette area of the
  // garment as it lies / that of the garment laid out flat (the metric of current
  // cloth-unfolding work); -1 when not placed.
  bool placed = false;
  std::string place_failure;
  double coverage = -1;
  std::vector<AnchorPoint> true_anchors;  // truth: the test garment's anchors on its pattern
  // Cloth simulations run (pick-up hangs and let-go falls), let-go falls that re-hung
  // from the flat garment, and falls stopped by the time or CCD test cap still moving (sim.h).
  int hangs = 0, fallbacks = 0, unsettled = 0;
  int retries = 0;                         // falls and placings run again at half the time step after blowing up
  hardware::SimWorld::FallCost fall_cost;  // the let-go falls' steps and collision fail-safe rounds
  StageTimes times;
  double seconds = 0;
  Json ToJson() const;  // the trace (no meshes)
};

// Runs one trial on a fresh simulated world of the category's test garment. The first
// grasp is a random point of the garment (seeded). `progress` (optional) is told each
// step. Numerical failures of the simulation end the trial with `failure` set.
TrialResult RunTrial(const ReleaseModel& model, const std::string& category, const LoopOptions& options, uint64_t seed,
                     const std::function<void(const std::string&)>& progress = {});

// Top-down silhouette area of `lying` (world mesh on a table) over that of `garment`
// laid out flat, both rasterised at `metres_per_pixel`.
double Coverage(const TriMesh& lying, const Garment& garment, double metres_per_pixel = 0.003);

// How far two pinched pattern points are from being a desired pair (truth, m): over the
// pairs and both assignments, the least of the larger of the two distances to the
// pair's anchors; -1 when the garment has none of the pairs' anchors.
double DesiredPairDistance(const Garment& g, const std::vector<DesiredPair>& pairs, const Vec2& a, const Vec2& b);

// The test garment's labelled anchor nearest a pattern point.
std::string NearestAnchor(const Garment& g, const Vec2& uv);

// Rank (0-based) of the first of recognition's top `top_k` anchors that is `aimed` or a
// symmetry twin of it; -1 if none is, or `aimed` is empty (RecogniseOptions::plan_prior_top_k).
int PlanPriorRank(const recognition::Recognition& r, const std::string& aimed, int top_k);

// Whether the loop keeps both grippers (done) after a regrasp planned with f: f ≥ ξ, and
// the holder placed by an aimed regrasp (not the random first grasp, whose anchor is
// known from recognition alone).
bool MayStop(const ObjectiveOptions& o, double f, bool holder_regrasped);

// Why the hang a step just sensed does not support the belief a stop at f ≥ ξ stands on
// ("" when it does): the held anchor was kept by the plan prior beyond recognition's top
// `top_k` (TrustedAimedEntry), or the hang's own category by registration is not the one
// the plan stands on (LoopOptions::verify).
std::string UnsupportedBelief(const Recognised& r, int top_k);

// Index in `r.entries` (the category's entries, best first) of the first entry whose
// anchor is `aimed` or a symmetry twin of it (the plan prior beyond the top k); -1 if none is,
// or `aimed` is empty.
int TrustedAimedEntry(const recognition::Recognition& r, const std::string& aimed);

}  // namespace drape::unfolding
