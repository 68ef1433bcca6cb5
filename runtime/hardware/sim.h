// Simulated hardware: one garment, two arms with parallel grippers, a Kinect, an IR range
// sensor beside each gripper and a table, sharing one cloth state (SimWorld).
//
// Cloth model. The garment's state changes at the events that change what holds it,
// each simulated with the cloth core (generator/cloth ClothWorld: Bullet + collision
// handling, with the release's simulation settings and the garment's material fit) and
// run to rest; between them it is quasi-static:
//   - picked up from the table: it hangs from the grasp point until stationary (Hang
//     from that point of the flat pattern, as the database entries were made);
//   - held by both grippers, one lets go: it falls from the shape the two held and
//     settles below the remaining gripper (ClothWorld from the current state);
//   - held by both and placed on the table: PlaceFlat (ClothWorld: spread, lay, settle);
//   - a held garment follows its gripper rigidly (translation, and turns with the wrist);
//   - held by both grippers, it keeps the shape it had when the second one closed;
//   - released by its only gripper, it falls and is lost (GraspOutcome::kLost).
// What this leaves out: the swing and slip while a holding arm moves (arms are slow, the
// garment is at rest before each sweep), two-point sagging before placing, and
// cloth-gripper collisions of a moving arm (a path may pass through the cloth).
//
// Jaws. A closing gripper pinches the cloth nodes inside its jaws: a box around the jaw
// centre, jaw_opening (≈ 8 cm, the paper's Baxter hand) along the closing direction,
// finger_depth along the approach, finger_width across. No node: a miss; nodes of one
// layer of the garment: one layer; of both (or a seam, shared by both): both layers. The
// pinched point of the pattern is the captured node nearest the jaw centre. The jaws then
// hold the mesh nodes between the fingers and, of every face between them, its vertex
// nearest the jaw centre (the mesh is coarser than the fingers); a let-go fall and a
// placing hold exactly these, so the cloth world never grips cloth the jaws missed.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "garments/garment.h"
#include "generator/hang/hang.h"
#include "generator/hang/material.h"
#include "generator/sweep/sweep.h"
#include "runtime/hardware/hardware.h"

namespace drape::hardware {

struct SimOptions {
  HangOptions hang;  // the cloth model (use the release's recipe simulation settings)
  // The let-go falls' and the placings' cloth worlds take these instead of hang's (the
  // pick-up hang stays the database's hang): edges a step leaves further beyond the
  // strain bound than it found them merge into impact zones (collision.h
  // strain_monotone) and air drag (Bullet's face aerodynamics, ClothOptions::
  // drag_coefficient). Without them a garment falling from two grippers met itself at
  // 4–6 m/s and blew up (docs/simulation.md, "Hand-over falls").
  bool strain_monotone = true;
  double drag_coefficient = 1.2;
  // ... and the strain clamp's plain mass weighting (collision.h strain_lead_weight 1):
  // the default lead weighting (0.6) pumps energy into a swinging cloth, and a trouser
  // leg swinging down past the new grip whipped to 13–22 m/s with it (4.1 m/s at 1).
  double strain_lead_weight = 1.0;
  // A let-go fall stops, still moving, once its collision handling has run this many
  // pair CCD tests (SettleOptions::ccd_test_cap; 0: only the time cap); it then counts
  // as unsettled and still gets the hang's verdict. On the paper release the largest of
  // 120 falls that came to rest took 196 M; one that the fail-safe held together with
  // large rigid zones in every step took 1.33 G to its 16 s time cap, 1,023 s of
  // simulation (docs/unfolding.md, "What a fall costs").
  long long fall_ccd_test_cap = 400'000'000;
  double jaw_opening = 0.08;   // m (paper: ≈ 8 cm)
  double finger_depth = 0.03;  // m along the approach, centred on the jaw centre
  double finger_width = 0.02;  // m across the fingers
  double speed = 0.25;         // m/s of the arms (timing of paths only)
  SweepOptions camera;         // Kinect placement and noise; frames/degrees come per capture
  IrRangeOptions ir;           // range, noise (generator/sweep defaults: 4–40 cm, σ 1 mm + 1 %)
  // IR sensor on the gripper (x = closing, y = approach × closing, z = approach), metres:
  // beside the fingers (3 cm off the jaw plane), 6 cm behind the jaw centre.
  Vec3 ir_mount = Vec3(0, 0.03, -0.06);
  // Table top (world, m): 1.6 × 1.4 m, 0.75 m high, in front of the robot (room for
  // pants laid at full length).
  Eigen::AlignedBox3d table{Vec3(-0.8, 0.72, 0.2), Vec3(0.8, 0.75, 1.6)};
  void Validate() const;  // throws drape::Error naming the bad field
};

// Placing the garment flat with both grippers holding it (paper: "the two arms open to
// slightly stretch the garment and place it on a table"), simulated with the cloth core
// (generator/cloth ClothWorld: Bullet + collision handling, the table as a box collider
// with the material's friction): the grippers hold the cloth nodes their jaws pinched
// (the nodes between the fingers, and the vertex nearest the jaw centre of every face
// between them), step back from the table and lift until the garment, hanging
// level from both, would clear its top, move apart to `spread` × the pinched points'
// distance on the pattern above the near edge of the table, lower the garment while
// carrying it across the table so that it lies down behind them, open, and the cloth
// settles. Placed means: no crossing during the motion (the cloth core's verdict), the
// database hang's verdict on the lying garment, and every node on the table.
struct PlaceFlatOptions {
  double spread = 0.9;      // of the pinched points' distance on the flat pattern
  double lift_time = 1.0;   // s to lift clear of the table and spread, and again to carry above its near edge
  double lay_time = 2.0;    // s to lower and carry across the table
  double settle_cap = 3.0;  // s of settling at most after opening
  // Pads of the cloth world's grippers, m: at least this, and 1.5 mesh edges so that a
  // coarse mesh still has nodes between them.
  double min_pad = 0.03;
  void Validate() const;
};
struct PlaceFlatReport {
  bool ok = false;
  std::string failure;
  int held_nodes[2] = {0, 0};  // cloth-world nodes each gripper took
  double sim_time = 0;         // s simulated
  bool settled = false;
};

// What a gripper closing at a pose would take (SimWorld::ProbeGrasp; ground truth, for
// evaluation only: nothing changes).
struct GraspProbe {
  GraspReport report;            // as Close() there would report it
  Vec3 centroid = Vec3::Zero();  // world: mean of the cloth samples between the jaws
  Vec3 pinch = Vec3::Zero();     // world: the pinched point (the sample nearest the jaw centre)
  std::optional<Vec2> uv;        // its point on the flat pattern (m); none on a miss
};

// Where the garment is.
enum class ClothState { kOnTable, kHanging, kHeldByTwo, kLost };
const char* ClothStateName(ClothState s);

class SimWorld {
 public:
  // The garment (flat pattern, as built), its material and fit. Starts flat on the table,
  // front up, centred on the table top. Throws drape::Error on bad options.
  SimWorld(Garment garment, Material material, MaterialFit fit, const SimOptions& options, uint64_t seed);
  ~SimWorld();
  SimWorld(const SimWorld&) = delete;
  SimWorld& operator=(const SimWorld&) = delete;

  Arm& arm(int i);  // 0 and 1
  DepthCamera& camera();
  RangeSensor& ir(int arm);
  Table& table();

  // Both grippers hold the garment (ClothState::kHeldByTwo): lay it on the table (see
  // PlaceFlatOptions); afterwards the state is kOnTable, both grippers open, and mesh()
  // is the garment as it lies. A placing that blows up, or leaves the garment passing
  // through itself or beyond the release's strain acceptance bounds (a database hang's
  // verdict), is tried once more at half the time step and otherwise reported failed
  // (ok false, failure says why). Throws drape::Error in another state.
  PlaceFlatReport PlaceFlat(const PlaceFlatOptions& options = {});

  // Ground truth, for evaluation and pictures (the loop never decides on it).
  ClothState state() const;
  const TriMesh& mesh() const;  // current cloth, world frame
  const Garment& garment() const;
  int HeldVertex(int arm) const;              // pinched node of the garment, -1 if none
  std::vector<int> HeldNodes(int arm) const;  // nodes the arm's jaws hold (sorted; empty if none)
  std::optional<Vec2> HeldUv(int arm) const;  // pinched point on the flat pattern (m)
  // What a gripper closing at `pose` on the cloth as it is now would take (as
  // Arm::Close() would, without closing anything).
  GraspProbe ProbeGrasp(const GripperPose& pose) const;
  const SimOptions& options() const;
  // Hangs and let-go falls so far: their count and wall seconds in the cloth simulation.
  int hangs() const;
  // Let-go falls that re-hung from the flat garment (no cloth-world node between the
  // remaining gripper's pads), and that reached the time cap or the CCD test cap still moving.
  int fallbacks() const;
  int unsettled() const;
  // Falls and placings that blew up and were run again at half the time step.
  int retries() const;
  // What the let-go falls cost the cloth core (a retry at half the time step counts as a
  // fall): steps, steps that needed the collision fail-safe, its rounds, pair CCD tests
  // (summed, and the most in one fall).
  struct FallCost {
    int falls = 0, steps = 0, fail_safe_steps = 0;
    long zone_rounds = 0;
    long long ccd_tests = 0, max_ccd_tests = 0;
  };
  const FallCost& fall_cost() const;
  double simulation_seconds() const;
  double sensing_seconds() const;  // Kinect sweeps and IR readings

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace drape::hardware
