// Hanging a garment from one grasp point with a Bullet soft body until it is
// stationary (paper §"Simulating Deformable Objects"), finished by a KINSOL solve of
// the static force balance; and fitting a material's stiffness to its measured
// stretch (paper §"Parameter Adaptation").
//
// Model. One classic btSoftBody per job (btSoftRigidDynamicsWorld, nothing shared
// between calls): structural links along the mesh edges (Bullet link stiffness
// MaterialFit::stiffness), bending links across every interior edge (× the material's
// relative bending_stiffness), node masses from face areas × area density. Bullet's
// own soft-soft collision does not act inside one body, so layers and folds are kept
// apart by our proximity pass after every step (node vs non-adjacent triangle within
// layer_thickness, pushed back to the side it was on before the step).
// The gripper pins (mass 0) every node within jaw_width/2 of the grasp point.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/mesh.h"
#include "garments/garment.h"
#include "generator/cloth/rectangle.h"  // MakeRectangleGarment (the reference cloth of material fits)
#include "generator/hang/material.h"

namespace drape {

struct HangOptions {
  double time_step = 1.0 / 240;   // s; 1/60 does not settle
  int solver_iterations = 8;      // Bullet position iterations (piterations)
  // Bullet kDP: fraction of node velocity removed per step of time_step, 0..1. 0.03 (7 /s
  // at 1/240 s) over-damps the garment's soft twist about the vertical through the
  // gripper: it then creeps at ~0.1 rad/s for many seconds and does not settle by the
  // time cap (shirts from a shoulder/hem, pants from a leg); 0.01 settles them in 5–8 s.
  double damping = 0.01;
  bool self_collision = true;     // our layer/fold proximity pass
  double layer_thickness = 0.004; // m, minimum node–triangle distance kept by it
  // m: settled when no node moved more than this ... (3 mm: contact jitter and PBD
  // creep keep fine two-layer meshes above 1 mm; the equilibrium solve finishes the job)
  double settle_distance = 0.003;
  double settle_window = 0.25;    // s: ... over this window
  double min_time = 0.75;         // s simulated before settling may be declared
  double time_cap = 8.0;          // s simulated; not settled by then → retry/fail
  double jaw_width = 0.03;        // m; nodes within jaw_width/2 of the grasp point are held
  double jitter = 0.001;          // m, seeded start perturbation (breaks symmetry)
  double max_speed = 25.0;        // m/s; faster = blown up
  bool equilibrium_solve = true;  // KINSOL on the spring model after Bullet
  double equilibrium_tolerance = 1e-4;       // max |F_i|/(m_i g) to reach
  double equilibrium_max_displacement = 0.03;  // m; larger solves are rejected
  int equilibrium_iterations = 60;  // Newton iterations in total (cost cap)
  // A run that reaches time_cap still creeping by at most this much (m, max node move
  // over the last settle window) is handed to the equilibrium solve; when the solve
  // converges (equilibrium_tolerance, within equilibrium_max_displacement) that state is
  // accepted as stationary (HangStats::settled_by_equilibrium) instead of retrying.
  // 0 = never. A garment still moving more than this stays failed.
  double equilibrium_rescue_motion = 0.05;
  int equilibrium_rescue_iterations = 200;  // Newton cost cap of that rescue solve
  // FitMaterial's reference: a single-layer strip of cloth hung from the middle of one
  // end. (A towel hung from a corner curls and buckles, so pick→lowest-point distance
  // falls 5–10 % short of the flat diagonal whatever the stiffness; a strip hangs
  // straight and measures stretch alone.)
  double fit_width = 0.1, fit_height = 0.7;  // m
  double fit_edge_length = 0.025;            // m; use the garments' edge length
  double fit_tolerance_percent = 0.05;       // |reproduced − target| in stretch %
  int fit_max_iterations = 12;
  void Validate() const;
};

// A material's measured stretch turned into simulation stiffness.
struct MaterialFit {
  double stiffness = 0.5;          // Bullet structural link kLST (0, 1]
  double spring_stiffness = 0;     // membrane stiffness of the equilibrium spring model, N/m
  double target_stretch_percent = 0;
  double reproduced_stretch_percent = 0;   // Bullet, on the reference towel
  double equilibrium_stretch_percent = 0;  // spring model at equilibrium, same towel
  int iterations = 0;              // Bullet hangs used (secant on kLST)
  int equilibrium_iterations = 0;  // KINSOL iterations of the spring-stiffness fit
  bool converged = false;
  std::string note;                // e.g. target out of Bullet's reach at this resolution
  double wall_seconds = 0;         // timing only
};

// Deterministic; callers cache it per material (and per HangOptions).
MaterialFit FitMaterial(const Material& material, const HangOptions& options);

struct HangStats {
  double sim_time = 0;        // s simulated in the accepted run
  int steps = 0;
  double time_step = 0;       // s, of the accepted run
  double kinetic_energy = 0;  // J, Bullet's final state
  double max_speed = 0;       // m/s, Bullet's final state
  double strain_mean = 0;     // mean of (l − L0)/L0 over mesh edges, final state
  double strain_max = 0;      // max of (l − L0)/L0
  bool settled = false;       // windowed criterion met in Bullet
  // Bullet reached time_cap still creeping, and the equilibrium solve from its state
  // converged: the accepted state is the solver's (settled stays false).
  bool settled_by_equilibrium = false;
  double settle_motion = 0;   // m, max node move over the last settle window in Bullet
  double force_residual = 0;      // max |F_i| over free nodes (spring model), N, final state
  double force_residual_rel = 0;  // same / node weight
  double bullet_force_residual_rel = 0;  // before the equilibrium solve
  bool equilibrium_applied = false;    // state replaced by the solve's (converged or ≥10× better)
  bool equilibrium_converged = false;  // residual met equilibrium_tolerance
  int equilibrium_iterations = 0;
  double equilibrium_displacement = 0;  // m, max node move of the solve
  std::string equilibrium_message;
  int collision_corrections = 0;  // proximity corrections in the last step
  int retries = 0;
  double wall_seconds = 0;    // timing only (never hashed)
  double bullet_seconds = 0;  // timing only: inside stepSimulation
  double contact_seconds = 0;      // timing only: our proximity pass
  double equilibrium_seconds = 0;  // timing only: KINSOL solve + crossing check
};

struct HangResult {
  bool ok = false;
  std::string failure;  // reason when !ok
  TriMesh mesh;         // object frame: grasp point at origin, y up, hanging below; garment's F
  std::vector<int> held_vertices;  // pinned by the gripper, sorted
  HangStats stats;
};

// Hangs `garment` from the point `grasp_offset` (metres, on the flat pattern, i.e. in the
// garment's flat frame; z ignored) away from vertex `anchor_vertex`. Throws drape::Error
// on bad input; numerical failure is returned as ok=false. Thread-safe.
HangResult Hang(const Garment& garment, int anchor_vertex, const Vec3& grasp_offset,
                const Material& material, const MaterialFit& fit, const HangOptions& options,
                uint64_t seed);

// shear_frac = (L1 − L2)/L2 of a hung mesh (object frame: grasp at origin):
// L1 = |lowest vertex|, L2 = flat distance from the grasp point to that vertex.
double ShearFraction(const TriMesh& hung, const Points3& flat, const Vec3& flat_grasp);

}  // namespace drape
