// One pass of the regrasping loop, phase by phase (loop.h): the options each phase takes
// and what it decides and measures. A phase's record holds what the robot senses and
// decides; the simulated garment's truth, for evaluation only, sits in `Step::truth`.
//
//   observe    the garment turns in front of the Kinect → TSDF fusion → feature
//   recognise  category (by registration at every hang) and held anchor, the plan prior
//   plan       registration candidates, the kept one's plan (Eq. finalobj) and the
//              regrasp point (registered, the lowest point or the hanging end's)
//   regrasp    the IR scan across the point (LoG), the free gripper closes there; then
//              both keep hold (f ≥ ξ) or the old gripper lets go
//
// A new phase (e.g. verifying the held anchor before planning) is an options struct in
// LoopOptions, a record in Step, a member of Trial in its own file (trial.h) and a call
// in Trial::Run (loop.cpp); its trace goes into trace.cpp's StepJson.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/json.h"
#include "common/mesh.h"
#include "runtime/hardware/hardware.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/unfolding/candidates.h"
#include "runtime/unfolding/objective.h"
#include "runtime/unfolding/refine.h"

namespace drape::unfolding {

// ---------------------------------------------------------------- options per phase

struct ObserveOptions {
  hardware::CaptureOptions capture;  // Kinect frames per turn, 360° one way and back
  // m: the holding gripper's height while the garment turns; 0: the release's rig, its
  // test sensing's camera.gripper_height (generator/sweep/sweep.h).
  double sensing_height = 0;
  int fusion_threads = 0;  // TSDF fusion threads (<= 0: all cores); no effect on results
  void Validate() const;   // throws drape::Error naming the bad field
};

struct RecogniseOptions {
  bool weighted = true;         // learned weights (false: unweighted Eq. match, an ablation)
  bool category_known = false;  // recognition is told the category (else by registration at every hang)
  // What a category left out of a hang's registration (by the height gate, or as not among
  // the two nearest categories) counts there beyond that hang's largest score (category.h
  // SummedFitCategory); >= 0.
  double refit_absent_penalty = 0.5;
  // After a regrasp the aimed anchor (or its symmetry twin) is kept: as recognition's
  // anchor of that rank when it is among its top k, else as the anchor's best-scored
  // database entry (TrustedAimedEntry). 0..5 (recognition lists 5).
  int plan_prior_top_k = 3;
  void Validate() const;  // throws drape::Error naming the bad field
};

struct PlanOptions {
  ObjectiveOptions objective;  // Eq. finalobj: σ, ξ, the least separation of two grasps
  // Database entries registered onto the reconstruction (recognition's answer first,
  // candidates.h), the one that fits best after rigid registration kept; 1..10.
  int candidates = 5;
  bool nonrigid = true;       // non-rigid registration after the rigid (false: R only, an ablation)
  LowestPointOptions lowest;  // the regrasp point at the reconstruction's lowest point
  HangingEndOptions hanging;  // the regrasp point above a hanging end (an elbow above its cuff)
  void Validate() const;      // throws drape::Error naming the bad field
};

struct RegraspOptions {
  bool ir_refinement = true;  // the IR scan (false: close at the predicted point, an ablation)
  RefineOptions refine;       // the scan's samples and the LoG
  double standoff = 0.12;     // m: the scan runs this far before the predicted point
  double grasp_depth = 0.01;  // m: the jaws close this far past the surface reading
  void Validate() const;      // throws drape::Error naming the bad field
};

// ---------------------------------------------------------------- one step's record

// Observe: the turning garment's reconstruction (the holder's object frame: grasp point
// at the origin, y up).
struct Observation {
  int frames = 0;
  TriMesh recon;
};

// Recognise: the category and the held anchor.
struct Recognised {
  recognition::Recognition recognition;  // after the plan prior; its best is the kept candidate after planning
  std::string category;                  // the category the pose was recognised within and planned on
  bool category_switched = false;        // a later hang changed the trial's category at this step
  Json category_fit;              // this hang's category by registration (category_fit.h ToJson); null when known
  std::string aimed_anchor;       // where the last regrasp aimed ("" at the first step)
  std::string recognised_anchor;  // recognition's own answer, before the plan prior
  int prior_rank = -1;            // rank of the aimed anchor (or twin) kept; -1: not within the top k
  bool prior_trusted = false;     // kept beyond recognition's top k (TrustedAimedEntry)
};

// One registration candidate: its plan and prediction (`truth` for evaluation only).
struct CandidateTrace {
  recognition::Candidate candidate;
  std::string next_anchor;  // the plan from this candidate's anchor
  double f = 0;
  double fit_rigid = -1, fit_final = -1;  // m: SymmetricFit after R and after the registration used
  double icp_rms = 0;
  double seconds = 0;             // registration + fit (timing only)
  Vec3 predicted = Vec3::Zero();  // world: its next anchor mapped onto the reconstruction
  bool usable = false;            // registered and planned (its fit can be kept)
  std::string note;               // why it could not be used, or the non-rigid fallback
  struct Truth {
    bool right = false, twin = false;  // its anchor is the held one / a twin of it
    double predicted_error = -1;       // m: its prediction to its next anchor (or a twin, nearer); -1 unplanned
  } truth;
};

// Plan: the candidates, the kept one's plan and the regrasp point.
struct Planned {
  std::vector<CandidateTrace> candidates;  // in recognition's order
  int kept = -1;                           // the best rigid fit; its entry is then recognition.best
  TriMesh registered;                      // the kept database mesh after R (+N), object frame
  std::vector<double> point_score;         // per registered vertex: nearness to the desired anchors (pictures)
  double icp_rms = 0;
  std::string current_anchor, next_anchor;
  double f = 0;                   // f(current, next)
  Vec3 predicted = Vec3::Zero();  // world: the regrasp point
  // The lowest point (PlanOptions::lowest): whether the kept database hang has the target
  // lowest (or the lowest near itself), and whether the reconstruction's lowest point was
  // taken for the regrasp point.
  bool lowest_target = false, lowest_near = false, lowest_taken = false;
  // The hanging end (PlanOptions::hanging): the end below the target ("" when it has none
  // or the database hang does not have it below), whether the point was taken from it, and
  // the pattern's anchor-to-end distance (m).
  std::string hanging_end;
  bool hanging_taken = false;
  double hanging_length = 0;
};

// Regrasp: the IR scan, where the free gripper closed and what it took.
struct Regrasped {
  Vec3 approach = Vec3::Zero();  // world, unit: the free gripper's approach direction
  std::vector<double> ir_ranges;
  RefineResult refine;
  Vec3 grasp = Vec3::Zero();  // world: the jaw centre where the free gripper closed
  hardware::GraspReport report;
  // After a pinch: the holder took its point by an aimed regrasp (not the random first
  // grasp), so f ≥ ξ may stop; and whether the holder let go.
  bool holder_regrasped = false;
  bool released_other = false;
};

// Truth (evaluation only): what the simulated garment says of the step.
struct StepTruth {
  Vec2 held_uv = Vec2::Zero();  // m, flat pattern: where the holding gripper pinches
  std::string held_anchor;      // the test garment's anchor nearest it
  // The cloth as it hung while sensed, in the reconstruction's object frame (vertices as
  // the test garment's), and the holder's pose then.
  TriMesh cloth;
  Vec3 holder_position = Vec3::Zero();
  double holder_wrist = 0;        // rad
  bool recognised_right = false;  // category right and anchor (after the plan prior) = held_anchor
  bool kept_right = false;        // the kept candidate's anchor is held_anchor
  int true_rank = -1;             // the first candidate whose anchor is held_anchor
  // The real garment's next anchor (or a symmetry twin of it, the same point for the plan
  // when the held anchor was taken for its twin), the nearest of them; distances from the
  // predicted and the grasp point to it in the world (m, -1 when not planned), and from
  // the pinched pattern point to it on the pattern (m, -1 without a pinch).
  std::string target_anchor;
  double predicted_error = -1, grasp_error = -1, regrasp_pattern_error = -1;
  std::optional<Vec2> regrasp_uv;  // m, flat pattern: the point the free gripper pinched
  std::string regrasp_anchor;      // the anchor nearest it
  // The regrasp point's error ladder: each rung's world point and its distance (m, -1
  // when not reached) to the target anchor's vertex on the cloth as it hangs: (a) the
  // kept database anchor after rigid registration, (b) after non-rigid registration (= a
  // when rigid only), (c) mapped onto the reconstruction (= the predicted point), (d)
  // after the IR scan (= the grasp), (e) where the jaws closed: the centroid of the cloth
  // between them, and the pinched point. Offsets of (c) and (d) from the target in the
  // approach frame: along the closing direction, up, along the approach (+ = past it).
  struct Ladder {
    Vec3 rigid = Vec3::Zero(), nonrigid = Vec3::Zero(), closed = Vec3::Zero(), pinch = Vec3::Zero();
    double rigid_error = -1, nonrigid_error = -1, mapped_error = -1, refined_error = -1, closed_error = -1,
           pinch_error = -1;
    Vec3 mapped_offset = Vec3::Zero(), refined_offset = Vec3::Zero();
    // The jaws probed at the predicted point without the IR scan (what the ablation would
    // have closed on, on the same cloth): outcome, the pinch's distance to the target in
    // the world and on the pattern.
    std::string no_ir_outcome;
    double no_ir_pinch_error = -1, no_ir_pattern_error = -1;
  } ladder;
};

// Verify: before both grippers keep hold at f ≥ ξ, whether the hang just sensed (the
// holder's, this step's observation) supports the belief the plan stands on (Trial::Verify).
struct Verified {
  bool checked = false;  // the step reached f ≥ ξ on a holder an aimed regrasp placed
  bool passed = false;
  std::string why;  // why not, when checked and not passed
  // Truth: how far the two pinched points were from a desired pair when it was checked
  // (DesiredPairDistance, m; -1 unless both held): what a loop declaring on the belief
  // alone would have reported.
  double pair_distance = -1;
};

struct Step {
  Observation observe;
  Recognised recognise;
  Planned plan;
  Regrasped regrasp;
  Verified verify;
  StepTruth truth;
  std::string note;  // what went differently from the rules ("; " between notes)
};

}  // namespace drape::unfolding
