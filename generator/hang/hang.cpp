#include "generator/hang/hang.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "common/cpu_time.h"
#include "common/error.h"
#include "common/field_error.h"
#include "common/format.h"
#include "common/rng.h"
#include "common/timing.h"
#include "generator/cloth/measure.h"

namespace drape {

void HangOptions::Validate() const {
  auto bad = [](const auto& field, const char* name, const std::string& what) { BadField(field, name, what); };
  if (!(time_step > 1e-5 && time_step <= 1.0 / 30)) bad(time_step, "time_step", "must be in (1e-5, 1/30] s");
  if (solver_iterations < 1 || solver_iterations > 100)
    bad(solver_iterations, "solver_iterations", "must be in [1, 100]");
  if (!(damping >= 0 && damping < 1)) bad(damping, "damping", "must be in [0, 1)");
  if (!(layer_thickness > 0 && layer_thickness < 0.05))
    bad(layer_thickness, "layer_thickness", "must be in (0, 0.05) m");
  if (!(strain_limit > 0 && strain_limit <= 20))
    bad(strain_limit, "strain_limit", "must be in (0, 20] × the material's stretch");
  if (!(accept_strain_max > 0)) bad(accept_strain_max, "accept_strain_max", "must be > 0");
  if (!(accept_strain_p99 > 0)) bad(accept_strain_p99, "accept_strain_p99", "must be > 0");
  // Caps: a simulated hour or a metre of motion is a typo, not a setting (a hang
  // settles in seconds; one simulated second costs ~1 CPU-s per 1,000 nodes).
  if (!(settle_distance > 0 && settle_distance <= 1)) bad(settle_distance, "settle_distance", "must be in (0, 1] m");
  if (!(settle_window >= 4 * time_step && settle_window <= 100))
    bad(settle_window, "settle_window", "must be in [4 time steps, 100] s");
  if (!(min_time >= 0 && min_time <= 3600)) bad(min_time, "min_time", "must be in [0, 3600] s");
  if (!(time_cap > min_time + settle_window && time_cap <= 3600))
    bad(time_cap, "time_cap", "must exceed min_time + settle_window and be at most 3600 s");
  if (!(jaw_width > 0 && jaw_width < 0.5)) bad(jaw_width, "jaw_width", "must be in (0, 0.5) m");
  if (!(jaw_opening > 0 && jaw_opening < 0.5)) bad(jaw_opening, "jaw_opening", "must be in (0, 0.5) m");
  if (!(jitter >= 0 && jitter < 0.01)) bad(jitter, "jitter", "must be in [0, 0.01) m");
  if (!(max_speed > 0)) bad(max_speed, "max_speed", "must be > 0");
  if (!(drag_coefficient >= 0 && drag_coefficient <= 10))
    bad(drag_coefficient, "drag_coefficient", "must be in [0, 10]");
  if (!(fit_width > 0.05)) bad(fit_width, "fit_width", "must be > 0.05 m");
  if (!(fit_height > 0.05)) bad(fit_height, "fit_height", "must be > 0.05 m");
  if (!(fit_edge_length > 0.002 && fit_edge_length < 0.2))
    bad(fit_edge_length, "fit_edge_length", "must be in (0.002, 0.2) m");
  if (!(fit_tolerance_percent > 0)) bad(fit_tolerance_percent, "fit_tolerance_percent", "must be > 0");
  if (!(fit_bending_tolerance > 0 && fit_bending_tolerance < 0.5))
    bad(fit_bending_tolerance, "fit_bending_tolerance", "must be in (0, 0.5)");
  if (!(fit_hinge_constant >= 0 && fit_hinge_constant <= 100))
    bad(fit_hinge_constant, "fit_hinge_constant", "must be in [0, 100] (0: fitted)");
  if (fit_max_iterations < 2) bad(fit_max_iterations, "fit_max_iterations", "must be >= 2");
  if (!(friction_size > 2 * fit_edge_length)) bad(friction_size, "friction_size", "must exceed two fit edge lengths");
  if (!(friction_time > 0)) bad(friction_time, "friction_time", "must be > 0 s");
  if (!(friction_slide_distance > 0)) bad(friction_slide_distance, "friction_slide_distance", "must be > 0 m");
  if (!(friction_tolerance_deg > 0 && friction_tolerance_deg < 5))
    bad(friction_tolerance_deg, "friction_tolerance_deg", "must be in (0, 5)");
}

double ShearFraction(const TriMesh& hung, const Points3& flat, const Vec3& flat_grasp) {
  int lowest = 0;
  for (int i = 1; i < hung.NumVertices(); ++i)
    if (hung.V(i, 1) < hung.V(lowest, 1)) lowest = i;
  const double l1 = hung.V.row(lowest).norm();
  const double l2 = (flat.row(lowest).transpose() - flat_grasp).norm();
  return (l1 - l2) / l2;
}

namespace {

// The gripper for hanging: closing across the layers (world z, the flat garment's
// normal), pads in the garment's plane, at the grasp point (the origin).
Eigen::Isometry3d HangGripperPose() {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() << 0, 1, 0,  //
      0, 0, 1,            //
      1, 0, 0;            // gripper x → world z, y → world x, z → world y
  return p;
}

// Pads of jaw_width, widened to the nearest node's one ring when fewer than three nodes
// would be inside (start: the object-frame rest positions, grasp at the origin).
Jaw HangJaw(const TriMesh& start, const HangOptions& o) {
  Jaw jaw;
  jaw.opening = o.jaw_opening;
  jaw.pad_length = jaw.pad_width = o.jaw_width;
  auto inside = [&](const Vec3& p, double pad) {
    return std::abs(p.z()) <= jaw.opening / 2 && std::abs(p.x()) <= pad / 2 && std::abs(p.y()) <= pad / 2;
  };
  int count = 0, nearest = 0;
  for (int i = 0; i < start.NumVertices(); ++i) {
    count += inside(start.V.row(i).transpose(), o.jaw_width);
    if (start.V.row(i).norm() < start.V.row(nearest).norm()) nearest = i;
  }
  if (count >= 3) return jaw;
  double pad = 2 * start.V.row(nearest).cwiseAbs().head<2>().maxCoeff();
  const auto ring = VertexNeighbours(start);
  for (int v : ring[nearest]) pad = std::max(pad, 2 * start.V.row(v).cwiseAbs().head<2>().maxCoeff());
  jaw.pad_length = jaw.pad_width = pad * (1 + 1e-9) + 1e-12;
  return jaw;
}

// Object frame of the flat garment for hanging: the pattern (vertical, in the x–y plane)
// turned about z so that its centre of area is straight below the grasp point, grasp
// point at the origin.
Points3 StartPose(const TriMesh& mesh, const Vec3& grasp) {
  const Vec3 com = CentreOfArea(mesh);
  const Vec2 d(com.x() - grasp.x(), com.y() - grasp.y());
  const double angle = d.norm() > 1e-9 ? std::atan2(d.x(), -d.y()) : 0.0;  // rotate d onto −y
  const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix();
  Points3 start(mesh.NumVertices(), 3);
  for (int i = 0; i < start.rows(); ++i) start.row(i) = (R * (mesh.V.row(i).transpose() - grasp)).transpose();
  return start;
}

void CheckInput(const Garment& garment, int anchor_vertex, const MaterialFit& fit) {
  const TriMesh& mesh = garment.mesh;
  const int n = mesh.NumVertices();
  if (n < 3 || mesh.NumFaces() < 1) throw Error("hang: garment '" + garment.instance + "' has no mesh");
  if (anchor_vertex < 0 || anchor_vertex >= n)
    throw Error("hang: anchor vertex " + std::to_string(anchor_vertex) + " out of range for garment '" +
                garment.instance + "' (" + std::to_string(n) + " vertices)");
  if (!(fit.stiffness > 0 && fit.stiffness <= 1)) throw Error("hang: MaterialFit.stiffness must be in (0, 1]");
  if (!mesh.V.allFinite()) throw Error("hang: garment '" + garment.instance + "' has non-finite vertices");
}

struct Run {
  SettleReport settle;
  int finish_steps = 0;  // strict steps after settling (HangOptions::strain_zones off)
  GraspReport grasp;
  Points3 x;
  ClothTimings timings;
  double setup_seconds = 0;  // steady clock: before settling, less the jitter's collision pass
  double seconds = 0;        // steady clock: the whole run
};

// One simulation: the gripper closes on the flat garment at the origin, the start is
// perturbed by a seeded jitter (breaks symmetry), and the world settles.
Run RunHang(const Garment& garment, const Points3& start, const Material& material, const MaterialFit& fit,
            const HangOptions& o, double dt, uint64_t seed, const HangStart& how) {
  const double t0 = ClockSeconds();
  // Links take their rest lengths from the model's rest mesh: the start pose is the
  // flat garment moved rigidly, so it serves as the rest mesh too.
  const TriMesh rest{start, garment.mesh.F};
  ClothWorld world(
      MakeClothModel(rest, garment.layer, ClothMaterialFor(material, fit, o), HangClothOptions(material, o, dt)),
      start);
  Run run;
  const int g = world.AddGripper(HangJaw(rest, o), HangGripperPose());
  run.grasp = world.Close(g);
  DRAPE_CHECK(!run.grasp.miss, "hang: the gripper at the grasp point holds no node");
  Rng rng(DeriveSeed(seed, "hang/jitter"));
  Points3 dx(start.rows(), 3);
  for (int i = 0; i < dx.rows(); ++i)
    for (int c = 0; c < 3; ++c) dx(i, c) = o.jitter * rng.Uniform(-1, 1);
  world.Perturb(dx);
  if (how.spin != Vec3::Zero()) {
    // A lift's swing: the free nodes turn rigidly about the grasp point (the origin).
    ClothState s = world.State();
    for (int i = 0; i < s.x.rows(); ++i) s.v.row(i) = how.spin.cross(Vec3(s.x.row(i).transpose())).transpose();
    for (int i : world.HeldNodes(g)) s.v.row(i).setZero();
    world.SetState(s);
  }
  run.setup_seconds = ClockSeconds() - t0 - world.timings().collision_seconds;
  SettleOptions so;
  so.distance = o.settle_distance;
  so.window = o.settle_window;
  so.min_time = o.min_time;
  so.time_cap = o.time_cap;
  run.settle = world.Settle(so);
  // Settled with stretched edges left to the next step: finish with strict steps (zones
  // for stretched edges too), which bring the mesh back within the clamp's bound where
  // the clamp reaches it. The fail-safe holds an over-stretched edge's lead node where
  // the step left it and clamps the other end to it; an edge that still cannot be
  // brought within (both ends blocked) keeps its length inside a zone, and the
  // verdict's acceptance bounds decide.
  if (run.settle.settled && !o.strain_zones && o.self_collision) {
    world.SetStrainZones(true);
    const int finish = static_cast<int>(std::lround(o.settle_window / dt));
    for (int i = 0; i < finish; ++i) world.Step();
    run.finish_steps = finish;
    const std::string bad = world.Health();
    if (!bad.empty()) run.settle.settled = false, run.settle.failure = "after the finishing steps: " + bad;
  }
  run.x = world.positions();
  run.timings = world.timings();
  run.seconds = ClockSeconds() - t0;
  return run;
}

void RecordRun(const Run& run, HangStats& st) {
  st.steps = run.settle.steps + run.finish_steps;
  st.sim_time =
      run.settle.sim_time + run.finish_steps * (run.settle.steps > 0 ? run.settle.sim_time / run.settle.steps : 0);
  st.kinetic_energy = run.settle.kinetic_energy;
  st.max_speed = run.settle.max_speed;
  st.settled = run.settle.settled;
  st.settle_motion = run.settle.motion;
  st.held_nodes = run.grasp.nodes;
  st.held_layers = static_cast<int>(run.grasp.layers.size());
  const ClothTimings& t = run.timings;
  st.ccd_collisions = t.ccd_collisions;
  st.fail_safe_steps = t.fail_safe_steps;
  st.remaining_collisions = t.remaining_collisions;
  st.strain_violation_steps = t.strain_violation_steps;
}

// Adds a run's parts (steady-clock seconds) to st; Hang scales them to CPU time at the end.
void AddRunCost(const Run& run, HangStats& st) {
  const ClothTimings& t = run.timings;
  st.setup_seconds += run.setup_seconds;
  st.bullet_seconds += t.bullet_seconds;
  st.bend_seconds += t.bending_seconds;
  st.collision_seconds += t.collision_seconds;
  st.broad_seconds += t.broad_seconds;
  st.strain_seconds += t.strain_seconds;
  st.repulsion_seconds += t.proximity_seconds;
  st.collider_seconds += t.collider_seconds;
  st.ccd_seconds += t.ccd_seconds;
  st.zone_seconds += t.zone_seconds;
  st.step_seconds += t.step_seconds;
  st.settle_seconds += t.settle_seconds;
}

// The parts, steady-clock seconds until now, as shares of the call's thread CPU time.
void ScaleCost(double cpu, double wall, HangStats& st) {
  st.cpu_seconds = cpu;
  st.wall_seconds = wall;
  const double f = wall > 0 ? cpu / wall : 0;
  for (const HangCostPart& p : kHangCostParts)
    if (p.seconds != &HangStats::cpu_seconds) st.*p.seconds *= f;
}

void RecordMeasurement(const ClothMeasurement& m, HangStats& st) {
  st.intersecting_pairs = m.intersecting_pairs;
  st.min_distance = m.min_distance;
  st.strain_mean = m.strain.mean;
  st.strain_median = m.strain.median;
  st.strain_p99 = m.strain.p99;
  st.strain_max = m.strain.max;
}

// Horizontal distance (x–z) from the grasp point (the origin) to the centre of area.
double ComOffset(const TriMesh& hung) {
  const Vec3 com = CentreOfArea(hung);
  return std::hypot(com.x(), com.z());
}

// Why the hung mesh may not be published ("" = it may): never settled (or blew up),
// intersects itself, or breaks a strain bound.
std::string Verdict(const SettleReport& settle, const ClothMeasurement& m, const Material& material,
                    const HangOptions& o) {
  if (!settle.settled) return settle.failure;
  return MeasurementVerdict(m, material, o, "hung mesh");
}

}  // namespace

std::string MeasurementVerdict(const ClothMeasurement& m, const Material& material, const HangOptions& o,
                               const std::string& what) {
  if (m.intersecting_pairs > 0)
    return what + " intersects itself: " + std::to_string(m.intersecting_pairs) + " triangle pairs (CGAL exact test)";
  auto over = [&](const char* which, double strain, double bound) {
    return "edge strain " + std::string(which) + " " + FormatFixed(100 * strain, 2) + " % exceeds " +
           FormatFixed(bound, 2) + " × the material's stretch (" + FormatFixed(material.stretch_percent, 2) + " %)";
  };
  const double stretch = material.stretch_percent / 100;
  if (m.strain.max > o.accept_strain_max * stretch) return over("max", m.strain.max, o.accept_strain_max);
  if (m.strain.p99 > o.accept_strain_p99 * stretch) return over("p99", m.strain.p99, o.accept_strain_p99);
  return "";
}

ClothMaterial ClothMaterialFor(const Material& material, const MaterialFit& fit, const HangOptions& o) {
  ClothMaterial cm;
  cm.area_density = material.area_density;
  cm.link_stiffness = fit.stiffness;
  cm.bending = material.bending_stiffness;
  cm.bending_rigidity = material.bending_rigidity;
  cm.bending_scale = fit.bending_scale;
  cm.crease_yield = material.crease_recovery_deg > 0 ? fit.crease_yield : material.crease_yield;
  cm.crease_weakening = material.crease_weakening;
  cm.max_strain = o.strain_limit * material.stretch_percent / 100;
  return cm;
}

ClothOptions ClothOptionsFor(const HangOptions& o, double dt) {
  ClothOptions co;
  co.time_step = dt;
  co.solver_iterations = o.solver_iterations;
  // kDP removes that fraction of the velocity every step: keep the damping per second
  // the same at a retry's smaller step.
  co.damping = 1 - std::pow(1 - o.damping, dt / o.time_step);
  co.collisions = o.self_collision;
  co.collision.thickness = o.layer_thickness;
  co.collision.strain_zones = o.strain_zones;
  co.collision.strain_monotone = o.strain_monotone;
  co.drag_coefficient = o.drag_coefficient;
  // Without repulsion the CCD and the impact zones alone keep every step
  // intersection-free (layers then keep at least the CCD margin, min_separation,
  // instead of layer_thickness, apart).
  if (!o.repulsion) co.collision.proximity_iterations = 0;
  co.max_speed = o.max_speed;
  return co;
}

ClothOptions HangClothOptions(const Material& material, const HangOptions& o, double dt) {
  ClothOptions co = ClothOptionsFor(o, dt);
  co.collision.cloth_friction = material.FrictionCoefficient();
  return co;
}

HangResult Hang(const Garment& garment, int anchor_vertex, const Vec3& grasp_offset, const Material& material,
                const MaterialFit& fit, const HangOptions& options, uint64_t seed, const HangStart& how) {
  const double wall0 = ClockSeconds(), cpu0 = ThreadCpuSeconds();
  options.Validate();
  material.Validate();
  CheckInput(garment, anchor_vertex, fit);
  const Vec3 grasp = garment.mesh.V.row(anchor_vertex).transpose() + Vec3(grasp_offset.x(), grasp_offset.y(), 0);
  const Points3 start = StartPose(garment.mesh, grasp);

  // Not settled, blown up, or not publishable (intersecting itself, over a strain
  // bound): once more at half the step — stiffer and more stable, and the strain clamp
  // and the collision handler get twice the passes per simulated second. A hang that
  // passes at the first attempt is never re-run, so its entry does not change.
  Run run;
  double dt = options.time_step;
  HangResult result;
  HangStats& st = result.stats;
  result.mesh.F = garment.mesh.F;
  ClothMeasurement m;
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (attempt > 0) {
      ++st.retries;
      dt /= 2;
    }
    run = RunHang(garment, start, material, fit, options, dt, seed, how);
    AddRunCost(run, st);
    result.mesh.V = run.x.allFinite() ? run.x : start;
    const double tm = ClockSeconds();
    m = MeasureCloth(result.mesh, garment.mesh.V);
    const double measure = ClockSeconds() - tm;
    st.measure_seconds += measure;
    result.failure = Verdict(run.settle, m, material, options);
    if (result.failure.empty()) break;
    if (attempt == 0) {
      st.retry_seconds = run.seconds + measure;
      st.retry_reason = result.failure;
    }
  }
  RecordRun(run, st);
  st.time_step = dt;
  st.strain_limit = options.strain_limit * material.stretch_percent / 100;
  result.held_vertices = run.grasp.node_ids;
  RecordMeasurement(m, st);
  st.com_offset = ComOffset(result.mesh);
  if (!result.failure.empty() && st.retries > 0) {
    result.failure += " (after a retry at time_step " + FormatNumber(dt) + " s)";
  }
  result.ok = result.failure.empty();
  ScaleCost(ThreadCpuSeconds() - cpu0, ClockSeconds() - wall0, st);
  return result;
}

}  // namespace drape
