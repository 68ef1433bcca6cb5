// Hanging a garment from one grasp point until it is stationary (paper §"Simulating
// Deformable Objects") as one use of the cloth core (generator/cloth/world.h): one
// gripper closes on the flat garment at the grasp point and the world settles; and
// fitting a material's stiffness to its measured stretch and its friction to its
// measured friction angle (paper §"Parameter Adaptation").
//
// Model. The garment is a Bullet soft body (links along mesh edges with kLST =
// MaterialFit::stiffness, bending links × the material's bending_stiffness, node masses
// from face areas × area density), made intersection-free and strain-limited after
// every step by the collision handler (generator/cloth/collision.h: edges clamped to
// strain_limit × the material's stretch, VF + EE repulsion within layer_thickness,
// continuous collision detection, rigid impact zones). There is no equilibrium solve
// any more: the state returned is the settled simulation's own, measured (CGAL's exact
// self-intersection test, clearance, edge strain) and failed with its reason when it
// intersects itself, breaks the strain bounds or never settled.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/mesh.h"
#include "garments/garment.h"
#include "generator/cloth/measure.h"
#include "generator/cloth/rectangle.h"
#include "generator/cloth/world.h"
#include "generator/hang/material.h"

namespace drape {

struct HangOptions {
  double time_step = 1.0 / 240;  // s; 1/60 does not settle
  int solver_iterations = 8;     // Bullet position iterations (piterations)
  // Bullet kDP: fraction of node velocity removed per step of time_step, 0..1 (kept per
  // second at a retry's half step). 0.01 settles shirts and pants in 5–8 s; 0.03
  // over-damps the garment's twist about the gripper.
  double damping = 0.01;
  // Run the collision handler (self contact, strain limit). Off only to measure its cost.
  bool self_collision = true;
  double layer_thickness = 0.004;  // m: VF/EE pairs closer than this are repelled ...
  // ... when repulsion is on (the handler re-clamps the strain after it). Off, only CCD
  // and the impact zones keep the mesh intersection-free: layers then rest ~1e-8 m apart
  // and most steps need the fail-safe (towel test: 821 of ~980 steps; on: 0, 2 mm apart).
  bool repulsion = true;
  // Edge strain limit as a multiple of the material's stretch (shear_frac): edges are
  // clamped to (1 + strain_limit × stretch)·L0 in every collision pass. A uniform strip
  // hung from one end carries a load growing linearly towards the grip, so its top edges
  // stretch about twice its mean (the measured stretch): 2× is the natural clamp; 1.8×
  // keeps the Gauss–Seidel clamp's residual inside the 2× p99 acceptance bound below,
  // and cuts off the grip concentration (50–100 % strain before this clamp).
  double strain_limit = 1.8;
  // Edges the clamp could not bring within that limit in a step are left to the next
  // step (false), not frozen into rigid impact zones (true; collision.h strain_zones):
  // zones that take in the held nodes ride with the gripper and held cloth up at the
  // grip (a shirt by its cuff: body bunched at the cuff, 0.75 m long instead of 1.47 m).
  // The acceptance bounds below still apply to the settled mesh.
  bool strain_zones = false;
  // Edges that a step leaves beyond the limit and longer than it found them merge into
  // zones all the same (collision.h strain_monotone: violations never compound), and
  // air drag (cloth/world.h ClothOptions::drag_coefficient, Bullet's face aerodynamics;
  // 0: none). Off for hanging from the flat garment: a hang starts at rest, never met
  // the compounding, and turning either on changes every release's bytes (see
  // docs/simulation.md, "Hand-over falls"); the unfolding's let-go falls and placings
  // (runtime/hardware) turn both on.
  bool strain_monotone = false;
  double drag_coefficient = 0;
  // Acceptance: a hung mesh whose edge strain max / p99 exceed these multiples of the
  // material's stretch is failed (so is one that intersects itself or never settled).
  double accept_strain_max = 3.0;
  double accept_strain_p99 = 2.0;
  // m: settled when no node moved more than this ... (3 mm: contact jitter keeps fine
  // two-layer meshes above 1 mm)
  double settle_distance = 0.003;
  double settle_window = 0.25;  // s: ... over this window
  double min_time = 0.75;       // s simulated before settling may be declared
  double time_cap = 8.0;        // s simulated; not settled by then → retry/fail
  // The gripper (cloth/world.h Jaw): pads jaw_width × jaw_width, open jaw_opening across
  // the layers; it holds the nodes inside that box around the grasp point (at least the
  // nearest node's one ring: a jaw narrower than the mesh would hold one node, about
  // which the garment spins without settling).
  double jaw_width = 0.03;    // m
  double jaw_opening = 0.08;  // m (Baxter's parallel gripper opens about 8 cm)
  double jitter = 0.001;      // m, seeded start perturbation (breaks symmetry)
  double max_speed = 25.0;    // m/s; faster = blown up
  // FitMaterial's stretch reference: a single-layer strip of cloth hung from the middle
  // of one end (a towel hung from a corner curls and buckles; a strip hangs straight and
  // measures stretch alone).
  double fit_width = 0.1, fit_height = 0.7;  // m
  double fit_edge_length = 0.025;            // m; use the garments' edge length
  double fit_tolerance_percent = 0.05;       // |reproduced − target| in stretch %
  double fit_bending_tolerance = 0.01;       // |reproduced − target| / target bending length
  // > 0: the hinge constant C is this, not fitted (FitMaterial then fits kLST alone, by
  // secant, with no cantilever runs); 0: C fitted to the bending length with kLST.
  double fit_hinge_constant = 0;
  int fit_max_iterations = 12;
  // FitMaterial's friction reference: a flat single-layer square of this side on a
  // table tilted by the measured friction angle (paper: the angle at which the garment
  // starts to slide); "slides" = its centroid moves more than friction_slide_distance
  // within friction_time after landing.
  double friction_size = 0.24;             // m
  double friction_time = 1.5;              // s
  double friction_slide_distance = 0.005;  // m
  double friction_tolerance_deg = 0.1;     // bracket width of the angle found, degrees
  void Validate() const;
};

// A material's measured stretch and friction turned into simulation parameters.
struct MaterialFit {
  double stiffness = 0.5;    // Bullet structural link kLST (0, 1]
  double bending_scale = 1;  // hinge bending's constant C (generator/cloth/bending.h)
  double target_stretch_percent = 0;
  double reproduced_stretch_percent = 0;  // on the reference strip, with the strain limit
  // With hinge bending: the bending length c = (B/w)^(1/3) measured and reproduced by
  // the cantilever at fit_edge_length (cantilever.h), m (reproduced: 0 when C was given,
  // HangOptions::fit_hinge_constant).
  double target_bending_length = 0;
  double reproduced_bending_length = 0;
  int iterations = 0;  // reference runs used (with hinge bending: KINSOL's evaluations of both references)
  // With a measured crease recovery angle (Material::crease_recovery_deg): the yield
  // curvature (1/m) whose lab crease test (lab.h) at fit_edge_length opens to it, and
  // the angle that test reproduced (degrees). 0 otherwise: the material's crease_yield.
  double crease_yield = 0;
  double reproduced_crease_recovery_deg = 0;
  int crease_iterations = 0;  // crease tests run
  bool converged = false;
  double friction = 0;        // Coulomb μ of the cloth on colliders (tables)
  double cloth_friction = 0;  // Coulomb μ of the cloth on itself: the lab's tests (lab.h) set it; FitMaterial leaves 0
  double target_friction_deg = 0;  // measured: the tilt at which the garment starts to slide
  // Reproduced: the tilt at which the reference square starts to slide with `friction`
  // (midpoint of a bracket friction_tolerance_deg wide: stays below, slides above).
  double reproduced_friction_deg = 0;
  int friction_iterations = 0;  // tilted-table runs used
  std::string note;             // e.g. target out of Bullet's reach at this resolution
  double wall_seconds = 0;      // timing only
};

// Deterministic; callers cache it per material (and per HangOptions). Throws
// NumericalError when a reference run fails.
MaterialFit FitMaterial(const Material& material, const HangOptions& options);
// What FitMaterial's result depends on, as a key: the material's values (after any
// jitter) and the fit's resolution. Equal keys, equal fits; a build fits once per key.
std::string FitKey(const Material& material, const HangOptions& options);

// The tilt (degrees) at which the reference square starts to slide with Coulomb
// friction mu on the table, found by bisection to options.friction_tolerance_deg in
// [lo_deg, hi_deg]; *runs counts the simulations. (FitMaterial's friction check.)
double SlidingAngle(double mu, const Material& material, const MaterialFit& fit, const HangOptions& options,
                    double lo_deg, double hi_deg, int* runs = nullptr);
// Did the reference square slide on a table tilted by tilt_deg with friction mu?
bool SlidesOnTilt(double tilt_deg, double mu, const Material& material, const MaterialFit& fit,
                  const HangOptions& options);

struct HangStats {
  double sim_time = 0;  // s simulated in the accepted run
  int steps = 0;
  double time_step = 0;       // s, of the accepted run
  double kinetic_energy = 0;  // J, final state
  double max_speed = 0;       // m/s, final state
  bool settled = false;       // windowed criterion met
  double settle_motion = 0;   // m, max node move over the last settle window
  int held_nodes = 0;         // nodes inside the gripper's jaw
  int held_layers = 0;        // garment layers among them
  // The hung mesh as measured (generator/cloth/measure.h).
  int intersecting_pairs = 0;  // CGAL exact self-intersection test
  double min_distance = 0;     // m, smallest distance between non-adjacent elements
  double strain_mean = 0;      // edge strain (l − L0)/L0 over the mesh edges
  double strain_median = 0;
  double strain_p99 = 0;
  double strain_max = 0;
  double strain_limit = 0;  // the clamp used (strain_limit × stretch)
  // m, horizontal distance from the grasp point to the hung mesh's centre of area: a
  // gripper that carried no moment would hold it straight below (0); the held patch
  // and the cloth's in-plane stiffness at the mesh's resolution move it sideways.
  double com_offset = 0;
  // Collision handling over the accepted run.
  long ccd_collisions = 0;         // colliding pairs found by CCD, summed over steps
  int fail_safe_steps = 0;         // steps that needed rigid impact zones
  long remaining_collisions = 0;   // crossings left by the handler (0 with one still gripper)
  int strain_violation_steps = 0;  // steps that ended with an edge beyond the strain clamp
  int retries = 0;                 // runs repeated at half the step (not settled or not publishable)
  // Timing only (never hashed), from here down. cpu_seconds is the thread CPU time of the
  // whole call, every attempt; the parts below are its shares (thread CPU seconds, summed
  // over the attempts: the phases are timed on the steady clock and scaled by the call's
  // CPU/wall ratio, see cloth/world.h ClothTimings). cpu_seconds − their sum is what no
  // part names (input checks, the start pose; milliseconds).
  double wall_seconds = 0;
  double cpu_seconds = 0;
  double setup_seconds = 0;      // the model and world, the grasp, the start jitter
  double bullet_seconds = 0;     // inside Bullet's stepSimulation
  double bend_seconds = 0;       // hinge bending forces and plasticity (cloth/bending.h)
  double collision_seconds = 0;  // the collision handler: the six below + its own overhead
  double broad_seconds = 0;      // ... its broad phase
  double strain_seconds = 0;     // ... strain limiting (the clamp and the strain checks)
  double repulsion_seconds = 0;  // ... VF/EE repulsion
  double collider_seconds = 0;   // ... box colliders (none in a hang)
  double ccd_seconds = 0;        // ... CCD + impulses
  double zone_seconds = 0;       // ... rigid impact zones (fail-safe)
  double step_seconds = 0;       // the rest of each step (grippers, copies to and from Bullet)
  double settle_seconds = 0;     // the settling test between steps
  double measure_seconds = 0;    // CGAL test + clearance + strain
  double retry_seconds = 0;      // of cpu_seconds: the attempts not kept (a retry followed)
  // Why the first attempt was not kept (its failure, e.g. "edge strain max … exceeds …"),
  // empty when it was: the build's timing record keeps it, so a slow build can be read.
  std::string retry_reason;
};

// HangStats' cost in parts, by name: the call's thread CPU time ("cpu") and its shares.
// Hang scales every share to CPU time through this list, and the build records each as
// "hang.<name>", so a part added here is both scaled and recorded.
struct HangCostPart {
  const char* name;
  double HangStats::*seconds;
};
inline constexpr HangCostPart kHangCostParts[] = {{"cpu", &HangStats::cpu_seconds},
                                                  {"setup", &HangStats::setup_seconds},
                                                  {"bullet", &HangStats::bullet_seconds},
                                                  {"bend", &HangStats::bend_seconds},
                                                  {"collision", &HangStats::collision_seconds},
                                                  {"broad", &HangStats::broad_seconds},
                                                  {"strain", &HangStats::strain_seconds},
                                                  {"repulsion", &HangStats::repulsion_seconds},
                                                  {"colliders", &HangStats::collider_seconds},
                                                  {"ccd", &HangStats::ccd_seconds},
                                                  {"zones", &HangStats::zone_seconds},
                                                  {"step", &HangStats::step_seconds},
                                                  {"settle", &HangStats::settle_seconds},
                                                  {"measure", &HangStats::measure_seconds},
                                                  {"retry", &HangStats::retry_seconds}};

struct HangResult {
  bool ok = false;
  std::string failure;             // reason when !ok
  TriMesh mesh;                    // object frame: grasp point at origin, y up, hanging below; garment's F
  std::vector<int> held_vertices;  // held by the gripper, sorted
  HangStats stats;
};

// How the flat garment starts its fall. spin: every free node starts with velocity
// ω × x (x from the grasp point; rad/s), the swing a lift gives it; zero: at rest.
struct HangStart {
  Vec3 spin = Vec3::Zero();
};

// Hangs `garment` from the point `grasp_offset` (metres, on the flat pattern, i.e. in the
// garment's flat frame; z ignored) away from vertex `anchor_vertex`. Throws drape::Error
// on bad input; numerical failure (blow-up, never settled, self-intersecting or
// over-stretched result) is returned as ok=false with the reason. Thread-safe.
HangResult Hang(const Garment& garment, int anchor_vertex, const Vec3& grasp_offset, const Material& material,
                const MaterialFit& fit, const HangOptions& options, uint64_t seed, const HangStart& start = {});

// The cloth core's material and options for a fit and these options at step dt (s; a
// retry halves it): one model for hanging and the material fits' reference runs.
ClothMaterial ClothMaterialFor(const Material& material, const MaterialFit& fit, const HangOptions& options);
ClothOptions ClothOptionsFor(const HangOptions& options, double dt);
// ClothOptionsFor with the garment's layers holding on each other: Coulomb μ = the
// material's tan(friction_deg), the μ with which the lab's incline test (lab.h) starts a
// sheet sliding on a sheet at the friction angle. What a hang and the unfolding's falls
// and placings run with; the fits' single-layer references keep 0.
ClothOptions HangClothOptions(const Material& material, const HangOptions& options, double dt);

// Why a simulated state measured as `m` may not be published ("" = it may): `what`
// (e.g. "hung mesh") intersects itself, or an edge strain breaks the options'
// acceptance bounds (accept_strain_max, accept_strain_p99 × the material's stretch).
// A hang's verdict; placings on a table get the same one.
std::string MeasurementVerdict(const ClothMeasurement& m, const Material& material, const HangOptions& options,
                               const std::string& what);

// shear_frac = (L1 − L2)/L2 of a hung mesh (object frame: grasp at origin):
// L1 = |lowest vertex|, L2 = flat distance from the grasp point to that vertex.
double ShearFraction(const TriMesh& hung, const Points3& flat, const Vec3& flat_grasp);

}  // namespace drape
