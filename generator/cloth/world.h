// The cloth core: one garment as a classic Bullet soft body, made intersection-free and
// strain-limited after every Bullet step by the collision handler (collision.h), with
// static box colliders (table, floor) and kinematic grippers that close on the cloth
// where they actually are. Hanging (generator/hang), regrasping and folding all drive
// this one world.
//
// Model and state apart (MuJoCo's mjModel/mjData): a ClothModel (rest mesh, masses,
// links, material and solver parameters) is immutable and may be shared between
// worlds; a ClothWorld owns the changing state (node positions and velocities, time,
// gripper poses and what they hold) and can hand it out (State) and take it back
// (SetState), e.g. to try a motion and rewind.
//
// One step (ClothWorld::Step) of time_step seconds:
//   1. every closed gripper's pose is evaluated on its path at the step's end time, and
//      the nodes it holds are carried there rigidly (Bullet mass 0: they are driven,
//      Bullet's links pull on the free nodes only);
//   2. Bullet steps the soft body (in ClothModel::substeps steps): gravity, air drag
//      (Bullet's face aerodynamics), structural links (kLST = link_stiffness), and
//      bending: the hinge force (bending.h, a force on the nodes before each Bullet
//      step) or, without a bending rigidity, Bullet's bending links across interior
//      edges. Bullet's own collision is off (soft-soft and soft-rigid): the colliders
//      are ours;
//   3. the collision handler corrects the proposed positions from the last
//      intersection-free state: strain limiting (edges ≤ (1 + max_strain)·L0), VF and EE
//      repulsion, box colliders with Coulomb friction, continuous collision detection
//      and rigid impact zones; held nodes are infinitely heavy (inverse mass 0). It
//      ends with both no crossing and no edge beyond the bound, or reports which could
//      not be met (CollisionReport::remaining_collisions / strain_violations);
//   4. the corrected positions become the state (kept in double precision here;
//      Bullet's float copy follows them), velocities = (x1 − x0)/dt·(1 − kDP) (with
//      sub-steps: Bullet's velocity at the step's end plus the handler's correction
//      over dt, times (1 − kDP));
//   5. creases: the hinges' rest angles yield where the bending exceeds the material's
//      yield curvature (bending.h UpdatePlasticity).
// Deterministic: the same model, start state and calls give the same bytes on any
// thread (nothing is shared between worlds; no clock or global random state is read).
//
// Frames and units: world frame y up, gravity −y by default; metres, seconds,
// kilograms, radians.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "common/mesh.h"
#include "generator/cloth/bending.h"
#include "generator/cloth/collision.h"

namespace drape {

// What the simulation needs of a fabric (see generator/hang/material.h for the
// measured material and generator/hang's FitMaterial for how these are fitted).
struct ClothMaterial {
  double area_density = 0.2;    // kg/m² of ONE layer (node mass = density × area/3 per face)
  double link_stiffness = 0.5;  // Bullet structural link kLST, (0, 1]
  double bending = 0.02;        // bending links' kLST relative to link_stiffness, (0, 1]
                                // (see generator/hang/material.h for why this low)
  // Hinge bending (bending.h): B in N·m of one layer; > 0 replaces Bullet's bending
  // links (`bending` is then unused) by the dihedral-angle force with rest angles.
  double bending_rigidity = 0;
  double bending_scale = 1;  // the hinge energy's calibrated constant C (bending.h)
  // Creases (bending.h's plasticity): yield curvature in 1/m (0: none) and weakening.
  double crease_yield = 0;
  double crease_weakening = 0;
  // Strain limit: edges are clamped to at most (1 + max_strain)·L0 after every step
  // (collision.h step 1). ≤ 0: off. Hang sets it to a multiple of the measured stretch.
  double max_strain = 0.06;
  void Validate() const;  // throws drape::Error naming the field
};

// Solver parameters (immutable per model).
struct ClothOptions {
  double time_step = 1.0 / 240;  // s; 1/60 does not settle hung garments
  int solver_iterations = 8;     // Bullet position iterations (piterations)
  // Bullet kDP: fraction of node velocity removed per step of time_step, [0, 1).
  double damping = 0.01;
  // Run the collision handler after every step (self contact, colliders, strain
  // limit). Off only to measure what it costs or for a garment-free test of Bullet.
  bool collisions = true;
  CollisionOptions collision;  // thickness, CCD and fail-safe settings; its
                               // max_strain is replaced by ClothMaterial::max_strain
  Vec3 gravity{0, -9.81, 0};   // m/s²
  // Air drag, Bullet's own aerodynamic model (btSoftBody aeromodel F_TwoSidedLiftDrag:
  // every face takes 0.5·kDG·ρ·|v|²·A·cos θ against its velocity, θ between the face
  // normal and the velocity, a third to each node; no lift). kDG = drag_coefficient,
  // ρ = air_density; 0 turns it off. 1.2 is a flat plate broadside to the flow
  // (Hoerner, Fluid-Dynamic Drag, 3-16): a single layer of areal density σ then falls
  // flat at √(2σg/(ρ·kDG)), 1.6 m/s at 0.2 kg/m², 2.5 m/s at 0.45 kg/m², as cloth does
  // in air; edge-on (cos θ = 0) it feels none.
  double air_density = 1.2;  // kg/m³ (air at 20 °C)
  double drag_coefficient = 1.2;
  double max_speed = 25.0;  // m/s: a faster node means the simulation blew up
  void Validate() const;    // throws drape::Error naming the field
};

// Rest geometry, masses and links: built once, never changed.
struct ClothModel {
  TriMesh rest;                                   // rest (flat pattern) positions, m; the links' rest lengths
  std::vector<int> layer;                         // per node: garment layer (0 front, 1 back), empty if unknown
  Eigen::VectorXd mass;                           // kg per node
  std::vector<std::array<int, 2>> stretch_links;  // mesh edges
  std::vector<std::array<int, 2>> bend_links;     // vertices opposite each interior edge (Bullet's
                                                  // bending links; empty with hinge bending)
  BendingModel bending;                           // hinge bending (no hinges: Bullet's links)
  // Bullet steps per time_step: hinge bending is an explicit force, stable for steps
  // below 2/√λ (λ: BendingFrequencySquared of the rest mesh); each Bullet step is at
  // most 1/√λ (half of that) long.
  int substeps = 1;
  double bending_frequency = 0;  // √λ, 1/s (0 without hinge bending)
  ClothMaterial material;
  ClothOptions options;
  double total_mass = 0;  // kg
  double extent = 0;      // m, diagonal of the rest mesh's bounding box
};

// Throws drape::Error on bad input (empty mesh, non-finite positions, bad options,
// layer size ≠ #V when given).
std::shared_ptr<const ClothModel> MakeClothModel(const TriMesh& rest, const std::vector<int>& layer,
                                                 const ClothMaterial& material, const ClothOptions& options);

// The changing part of a simulation.
struct ClothState {
  Points3 x;             // #V×3 node positions, m
  Points3 v;             // #V×3 node velocities, m/s
  double time = 0;       // s since the world's start
  BendingState bending;  // rest angles (creases change them)
};

// A parallel-jaw gripper (the paper's Baxter hand opens about 8 cm). Gripper frame:
// origin midway between the two finger pads, x = closing direction (the pads sit at
// x = ±opening/2 when open), z = along the pad width, y = along the fingers (towards
// the wrist is +y). The jaw volume is the box between the open pads:
//   |x| ≤ opening/2, |y| ≤ pad_length/2, |z| ≤ pad_width/2.
// Closing holds every free cloth node inside that box where it is (the pads are
// assumed to pinch without squeezing the cloth flat: held nodes keep their place in the
// gripper frame).
struct Jaw {
  double opening = 0.08;     // m, pad-to-pad distance when open
  double pad_length = 0.03;  // m, pad size along the fingers (gripper y)
  double pad_width = 0.03;   // m, pad size across the fingers (gripper z)
  void Validate() const;     // throws drape::Error naming the field
};

// A time-parameterised gripper motion: poses at increasing times (s, world time),
// positions interpolated linearly and orientations by slerp; before the first key the
// first pose holds, after the last key the last.
struct GripperPath {
  std::vector<double> times;               // s, strictly increasing
  std::vector<Eigen::Isometry3d> poses;    // gripper frame → world, one per time
  Eigen::Isometry3d Pose(double t) const;  // requires at least one key
  void Validate() const;                   // throws drape::Error naming the field
};

// What closing a gripper caught.
struct GraspReport {
  bool miss = true;           // no free node inside the jaw
  int nodes = 0;              // nodes now held by this gripper
  std::vector<int> node_ids;  // sorted
  std::vector<int> layers;    // distinct garment layers among them, sorted (empty if unknown)
};

// Cumulative cost and counts since the world was made. The seconds (timing only, never
// hashed) are on the steady clock, cheap enough to read around every phase of a step (a
// CPU clock is a system call; see common/timing.h ClockSeconds): a caller that reports
// CPU time scales them by the thread CPU time it reads around its run, as Hang does.
// Every part of the world's work is one of them: the Bullet step, the collision handler's
// phases and its own overhead, the rest of Step, and Settle's checks between steps.
struct ClothTimings {
  int steps = 0;
  double bullet_seconds = 0;       // inside Bullet's stepSimulation
  double bending_seconds = 0;      // hinge forces and plasticity
  double broad_seconds = 0;        // collision handler: broad phase
  double strain_seconds = 0;       // ... strain limiting (the clamp and the strain checks)
  double proximity_seconds = 0;    // ... VF/EE repulsion
  double collider_seconds = 0;     // ... box colliders
  double ccd_seconds = 0;          // ... continuous collision detection + impulses
  double zone_seconds = 0;         // ... rigid impact zones (fail-safe)
  double collision_seconds = 0;    // the handler in total (its phases + its own overhead)
  double step_seconds = 0;         // the rest of Step: grippers, copies to and from Bullet, velocities
  double settle_seconds = 0;       // Settle's checks between steps (health, motion window)
  long ccd_collisions = 0;         // colliding pairs found by CCD, summed
  int fail_safe_steps = 0;         // steps that needed rigid impact zones
  int reverted_steps = 0;          // steps where the whole mesh moved as one zone
  long remaining_collisions = 0;   // crossings left (only with non-rigid kinematics), summed
  int strain_violation_steps = 0;  // steps that ended with an edge beyond the strain bound
  double max_strain = 0;           // largest edge strain (l − L0)/L0 at the end of any step
};

struct SettleOptions {
  double distance = 0.003;  // m: settled when no node moved more than this ...
  double window = 0.25;     // s: ... over this window (checked every window/4)
  double min_time = 0.75;   // s simulated (by this call) before settling may be declared
  double time_cap = 8.0;    // s simulated (by this call); not settled by then → failure
  // Collision work after which the call stops as at time_cap; 0: no cap. The work is the
  // pair CCD tests (CollisionReport::ccd_tests: every pass and fail-safe round) summed
  // over this call's steps. A state the fail-safe must hold together with large rigid
  // zones in every step can cost a third of a second per step.
  long long ccd_test_cap = 0;
  void Validate() const;  // throws drape::Error naming the field
};

struct SettleReport {
  bool settled = false;
  std::string failure;        // empty when settled; else blow-up reason, time cap or CCD test cap
  bool timed_out = false;     // reached time_cap or ccd_test_cap without blowing up
  int steps = 0;              // steps taken by this call
  int fail_safe_steps = 0;    // ... of which needed rigid impact zones
  long zone_rounds = 0;       // fail-safe rounds summed over them
  long long ccd_tests = 0;    // pair CCD tests summed over this call's steps
  double sim_time = 0;        // s simulated by this call
  double motion = 0;          // m, max node move over the last full window
  double kinetic_energy = 0;  // J, final state
  double max_speed = 0;       // m/s, final state
};

class ClothWorld {
 public:
  // `start`: initial positions (#V×3, intersection-free, e.g. the rest mesh moved
  // rigidly); velocities zero, time 0.
  ClothWorld(std::shared_ptr<const ClothModel> model, const Points3& start);
  ~ClothWorld();
  ClothWorld(const ClothWorld&) = delete;
  ClothWorld& operator=(const ClothWorld&) = delete;

  const ClothModel& model() const { return *model_; }

  // Static box colliders (table top, floor) with their own Coulomb friction. Returns its index.
  int AddCollider(const BoxCollider& box);
  const std::vector<BoxCollider>& colliders() const { return colliders_; }

  // A gripper, open, standing at `pose` (no path yet). Returns its index.
  int AddGripper(const Jaw& jaw, const Eigen::Isometry3d& pose);
  int NumGrippers() const { return static_cast<int>(grippers_.size()); }
  // Replaces the gripper's motion (times are world times, see time()). With an empty
  // path the gripper stays where it is.
  void SetPath(int gripper, const GripperPath& path);
  // Moves an open gripper instantly (no cloth is dragged). Throws if it is closed.
  void PlaceGripper(int gripper, const Eigen::Isometry3d& pose);
  Eigen::Isometry3d GripperPose(int gripper) const;  // at the current time
  // Holds every free node inside the jaw volume now (see Jaw); a miss holds nothing.
  // Closing a closed gripper adds the free nodes now inside.
  GraspReport Close(int gripper);
  // Holds the given nodes (those still free; indices checked) where they are now, as
  // jaws that closed on them elsewhere (e.g. the pinch a caller's own jaw model found).
  // Holding with a closed gripper adds them.
  GraspReport Hold(int gripper, const std::vector<int>& nodes);
  // Releases the held nodes: they get their mass back and move freely from the next step.
  void Open(int gripper);
  bool IsClosed(int gripper) const;
  const std::vector<int>& HeldNodes(int gripper) const;

  // Moves the free nodes by dx (#V×3, m) through the collision handler (so the result
  // is intersection-free), velocities unchanged: a seeded perturbation to break symmetry.
  void Perturb(const Points3& dx);

  // Turns the collision handler's strain_zones on or off from the next step (the model's
  // options say how the world starts). No-op without the handler.
  void SetStrainZones(bool on);

  // One step of time_step (see the file comment). Returns the collision handler's report.
  CollisionReport Step();
  // Steps until no node moved more than options.distance over options.window (after
  // options.min_time), or until a blow-up (NaN, speed > max_speed, kinetic energy above
  // 50 × weight (at g ≥ 9.81 m/s²) × extent), options.time_cap or options.ccd_test_cap. Deterministic.
  SettleReport Settle(const SettleOptions& options);
  // "" when the state is finite, no node is faster than max_speed and the kinetic
  // energy is below the cap; otherwise why not.
  std::string Health() const;

  double time() const { return time_; }
  const Points3& positions() const { return x_; }
  const Points3& velocities() const { return v_; }
  ClothState State() const;
  // Restores a state of this model (positions, velocities, time). Gripper holds are not
  // part of it: held nodes stay held and are moved with their gripper from the next step.
  void SetState(const ClothState& state);
  const ClothTimings& timings() const { return timings_; }
  double KineticEnergy() const;  // J
  const BendingState& bending() const { return bend_; }

 private:
  struct Bullet;  // Bullet's world and soft body
  struct Gripper {
    Jaw jaw;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // at time_
    GripperPath path;
    bool closed = false;
    std::vector<int> held;  // sorted
    Points3 local;          // held nodes in the gripper frame, row per held[k]
  };
  Eigen::Isometry3d PoseAt(const Gripper& g, double t) const;
  void SyncBullet();      // Bullet's nodes ← x_, v_, masses ← holds
  void AddHingeForces();  // the hinge force at Bullet's node positions, onto its free nodes
  void StepBullet(const std::vector<Eigen::Isometry3d>& pose1, Points3& x1, Points3* vb);
  void AddCollisionTimings(const CollisionReport& rep);

  std::shared_ptr<const ClothModel> model_;
  std::unique_ptr<Bullet> bullet_;
  std::unique_ptr<CollisionHandler> handler_;
  std::vector<BoxCollider> colliders_;
  std::vector<Gripper> grippers_;
  std::vector<int> holder_;  // per node: gripper holding it, −1 free
  Points3 x_, v_;
  BendingState bend_;
  Points3 force_;  // scratch: hinge forces of a Bullet step
  double time_ = 0;
  double kdp_ = 0;
  ClothTimings timings_;
  double step_total_seconds_ = 0;  // every Step in total (Settle's checks are what it adds)
};

}  // namespace drape
