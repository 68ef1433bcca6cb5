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

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/json.h"
#include "generator/feature/feature.h"
#include "generator/fusion/fusion.h"
#include "generator/recipe/recipe.h"
#include "generator/release/release.h"
#include "runtime/hardware/hardware.h"
#include "runtime/hardware/sim.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/registration/registration.h"
#include "runtime/unfolding/candidates.h"
#include "runtime/unfolding/category.h"
#include "runtime/unfolding/objective.h"
#include "runtime/unfolding/refine.h"

namespace drape::unfolding {

struct LoopOptions {
  ObjectiveOptions objective;
  RefineOptions refine;
  int max_regrasps = 4;         // regrasp attempts before giving up
  bool ir_refinement = true;    // ablation: false grasps the registered point directly
  bool nonrigid = true;         // ablation: false = rigid-only registration (R)
  bool weighted = true;         // ablation: false = unweighted recognition (Eq. match)
  bool category_known = false;  // true: recognition is told the category
  // Otherwise the category is decided by registration (recognition/category_fit.h) at
  // every hang: each of the nearest categories' best entries registered onto the hang's
  // reconstruction, and the trial's category the one of the least score summed over the
  // hangs so far (category.h SummedFitCategory). A category left out of a hang's
  // registration (by the height gate, or as not among the two nearest categories) counts
  // that hang's largest score plus this penalty; must be >= 0.
  double refit_absent_penalty = 0.5;
  // After a regrasp the held point is where the plan aimed: the aimed anchor (or its
  // symmetry twin) is kept, as recognition's top-k anchor when it ranks it among its top
  // k, else as the best-scored database entry of that anchor or its twin
  // (TrustedAimedEntry). Must be in 0..5 (recognition lists 5).
  int plan_prior_top_k = 3;
  // Registration candidates (candidates.h): register recognition's top `candidates`
  // database entries (its answer first; after a kept plan prior only entries of that
  // anchor or its twin) and predict from the one that fits the reconstruction best after
  // the rigid registration (SymmetricFit). 1 = recognition's answer alone. Must be in 1..10.
  int candidates = 5;
  // The regrasp point (candidates.h LowestPoint): when the point's database hang has the
  // target lowest (AnchorIsLowest, rigid registration), or the lowest near itself, the
  // reconstruction's lowest point (near the registered target) instead of the registered
  // anchor, the IR scan giving the depth only.
  LowestPointOptions lowest;
  // The regrasp point (candidates.h HangingEnd): when the target hangs straight above a
  // free end (an elbow above its cuff) and the point's database hang has that end below it,
  // the reconstruction's lowest point near the registered end, raised by the pattern's
  // anchor-to-end distance, instead of the registered anchor.
  HangingEndOptions hanging;
  hardware::CaptureOptions capture;  // frames per turn (paper ~550 both ways)
  int fusion_threads = 0;            // TSDF fusion threads (<= 0: all cores); no effect on results
  double standoff = 0.12;            // m: the IR scan runs this far before the predicted point
  double grasp_depth = 0.01;         // m: jaws go this far past the surface reading
  // m: the holding gripper's height while the garment turns; 0: the release's rig, its
  // test sensing's camera.gripper_height (generator/sweep/sweep.h; 1.5 m by default).
  double sensing_height = 0;
  // Evaluation only: unfolded when each gripper pinches within this distance (m, on the
  // flat pattern) of the desired pair's anchors.
  double success_distance = 0.06;
  bool place_flat = true;  // lay the garment on the table when f ≥ ξ (cloth core)
  hardware::PlaceFlatOptions place;
  void Validate() const;  // throws drape::Error naming the bad field
};

// What the runtime knows of a release: its database, weights, recipe options and
// database meshes (read on first use).
class ReleaseModel {
 public:
  // Throws drape::Error if the release has no recipe or no usable train entry, or if
  // `weights_path` is given and cannot be read.
  ReleaseModel(const std::filesystem::path& release_dir, const std::filesystem::path& weights_path);
  ~ReleaseModel();

  const Release& release() const;
  const Recipe& recipe() const;
  const recognition::Database& database() const;
  const recognition::Weights* weights() const;  // null without weights
  const recognition::Recognizer& recognizer(bool weighted) const;
  // Database entry's hung mesh (object frame), cached.
  const TriMesh& HungMesh(int entry) const;
  // Anchors (label, uv) of a database garment instance, in label order.
  std::vector<AnchorPoint> InstanceAnchors(const std::string& instance) const;
  // Flat-pattern position (m) of `anchor` on database `instance`; none if unknown.
  std::optional<Vec2> AnchorUv(const std::string& instance, const std::string& anchor) const;
  // Vertex of `anchor` in the meshes of database `instance`'s entries; -1 if unknown.
  int AnchorVertex(const std::string& instance, const std::string& anchor) const;
  // The category's test garment instances (from the recipe's test split): garment,
  // material and its cloth fit (the one the build recorded in the test entry's record,
  // else FitMaterial). Throws drape::Error if the category has none.
  struct TestGarment {
    Garment garment;
    Material material;
    MaterialFit fit;
    HangOptions hang;
    std::string instance;
  };
  std::vector<std::string> TestCategories() const;
  const TestGarment& TestInstance(const std::string& category) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// Seconds of one trial by stage (wall clock; timing only).
struct StageTimes {
  double simulation = 0, sensing = 0, fusion = 0, recognition = 0, registration = 0, refinement = 0;
  Json ToJson() const;
};

// One pass of the loop.
struct Step {
  // Truth: where the holding gripper pinches the pattern, and the nearest anchor.
  Vec2 held_uv = Vec2::Zero();
  std::string held_true_anchor;
  // Sensing and recognition.
  int frames = 0;
  TriMesh recon;  // object frame of the holder
  // Truth (evaluation only): the cloth as it hangs while sensed, in the same object frame
  // (vertices as the test garment's), and the holder's pose then.
  TriMesh cloth;
  Vec3 holder_position = Vec3::Zero();
  double holder_wrist = 0;
  recognition::Recognition recognition;
  bool recognised_right = false;  // category right and anchor = the nearest true anchor
                                  // (of the anchor used, after the plan prior)
  // The category the pose was recognised within and planned on, and whether it changed at
  // this step.
  std::string decided_category;
  bool category_switched = false;
  Json category_fit;         // this hang's category by registration (category_fit.h ToJson); null with category_known
  std::string aimed_anchor;  // where the last regrasp aimed ("" at the first step)
  std::string recognised_anchor;  // recognition's own answer, before the plan prior
  int prior_rank = -1;            // rank of the aimed anchor (or twin) kept; -1: not kept
  bool prior_trusted = false;     // kept beyond recognition's top k (TrustedAimedEntry)
  bool holder_regrasped = false;  // the holder took its point by an aimed regrasp (not the first grasp)
  // Registration candidates (LoopOptions::candidates), in recognition's order, and the
  // one kept (index; its entry is then recognition.best and its anchor the current one).
  struct CandidateTrace {
    recognition::Candidate candidate;
    std::string next_anchor;  // the plan from this candidate's anchor
    double f = 0;
    double fit_rigid = -1, fit_final = -1;  // SymmetricFit (m) after R and after the registration used
    double icp_rms = 0;
    double seconds = 0;             // registration + fit (timing only)
    Vec3 predicted = Vec3::Zero();  // world: its next anchor mapped onto the reconstruction
    bool usable = false;            // registered and planned (its fit can be kept)
    std::string note;               // why it could not be used, or the non-rigid fallback
    // Truth, evaluation only: the candidate's anchor is the held one / a twin of it; the
    // distance of its prediction to its next anchor (or a twin, nearer) as the cloth hangs
    // (m, -1 when not planned).
    bool right = false, twin = false;
    double predicted_error = -1;
  };
  std::vector<CandidateTrace> candidates;
  int kept = -1;
  bool kept_right = false;  // truth: the kept candidate's anchor is the held true anchor
  int true_rank = -1;       // truth: first candidate whose anchor is the held true anchor
  // Registration of the kept candidate.
  TriMesh registered;               // the database mesh after R (+N), object frame
  std::vector<double> point_score;  // per registered vertex: ScoreTable::PointScore of its uv
  double icp_rms = 0;
  // Plan.
  std::string current_anchor, next_anchor;
  double f = 0;                   // f(current, next)
  Vec3 predicted = Vec3::Zero();  // world
  // Refinement.
  std::vector<double> ir_ranges;
  RefineResult refine;
  Vec3 grasp = Vec3::Zero();  // world, where the free gripper closed
  // The lowest point (LoopOptions::lowest): whether the kept candidate's database hang has
  // the target lowest, and whether the reconstruction's lowest point was taken for it.
  bool lowest_target = false, lowest_taken = false;
  bool lowest_near = false;  // the target is not the lowest but the lowest near it (LowestPointOptions::near_radius)
  // The hanging end (LoopOptions::hanging): the end below the target ("" when it has none or the database
  // hang does not have it below), whether the point was taken from it, and the distance used.
  std::string hanging_end;
  bool hanging_taken = false;
  double hanging_length = 0;
  Vec3 approach = Vec3::Zero();
  // Regrasp.
  hardware::GraspReport regrasp;
  std::optional<Vec2> regrasp_uv;  // truth: pinched point of the pattern
  std::string regrasp_true_anchor;
  bool released_other = false;
  // Truth, for evaluation only: the real garment's next anchor (or a symmetry twin of it,
  // the same point for the plan when the held anchor was taken for its twin), nearest of
  // them; distances from the predicted and the grasp point to it in the world (m, -1
  // when not planned), and from the pinched pattern point to it on the pattern (m, -1
  // without a pinch).
  std::string target_true_anchor;
  double predicted_error = -1, grasp_error = -1, regrasp_pattern_error = -1;
  // Truth, evaluation only: the error ladder of the regrasp point, each rung's world point
  // and its distance (m, -1 when not reached) to the target anchor's vertex on the cloth
  // as it hangs now (target_true_anchor): (a) the matched database anchor after rigid
  // registration, (b) after non-rigid registration (= a with --rigid), (c) mapped onto the
  // reconstruction (= predicted), (d) after IR refinement (= grasp: the jaw centre sent
  // to), (e) where the jaws closed: the centroid of the cloth between them, and the
  // pinched point (the sample nearest the jaw centre, whose pattern point is judged).
  // Offsets of (c) and (d) from the target in the approach frame: along the closing
  // direction, up, and along the approach (+ = past the target).
  struct Ladder {
    Vec3 rigid = Vec3::Zero(), nonrigid = Vec3::Zero(), closed = Vec3::Zero(), pinch = Vec3::Zero();
    double rigid_error = -1, nonrigid_error = -1, mapped_error = -1, refined_error = -1, closed_error = -1,
           pinch_error = -1;
    Vec3 mapped_offset = Vec3::Zero(), refined_offset = Vec3::Zero();
    // The jaws closed at the registered point without IR refinement (what --no-ir would
    // have grasped on this same cloth; probed, nothing closes): outcome, distance of the
    // pinch to the target (world) and on the pattern.
    std::string no_ir_outcome;
    double no_ir_pinch_error = -1, no_ir_pattern_error = -1;
  } ladder;
  std::string note;
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
  std::string failure;  // why the trial ended early ("" if it ran to the end)
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
// symmetry twin of it; -1 if none is, or `aimed` is empty (LoopOptions::plan_prior_top_k).
int PlanPriorRank(const recognition::Recognition& r, const std::string& aimed, int top_k);

// Whether the loop keeps both grippers (done) after a regrasp planned with f: f ≥ ξ, and
// the holder placed by an aimed regrasp (not the random first grasp, whose anchor is
// known from recognition alone).
bool MayStop(const LoopOptions& o, double f, bool holder_regrasped);

// Index in `r.entries` (the category's entries, best first) of the first entry whose
// anchor is `aimed` or a symmetry twin of it (the plan prior beyond the top k); -1 if none is,
// or `aimed` is empty.
int TrustedAimedEntry(const recognition::Recognition& r, const std::string& aimed);

}  // namespace drape::unfolding
