#include "runtime/folding/run.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "runtime/folding/dissimilarity.h"

namespace drape::folding {
namespace {

struct FoldFrame {
  Vec3 u, v, w;
  double s = 0;
};

FoldFrame Frame(const Vec3& p0, const Vec3& p3) {
  FoldFrame f;
  f.v = Vec3::UnitY();
  Vec3 d = p3 - p0;
  f.s = d.norm();
  d.y() = 0;
  DRAPE_CHECK(d.norm() > 1e-9, "a fold that moves the grasp point straight up or down");
  f.u = d.normalized();
  f.w = f.u.cross(f.v);
  return f;
}

}  // namespace

RelativeTrajectory ToRelative(const CubicBezier& c) {
  const FoldFrame f = Frame(c.P[0], c.P[3]);
  // -> Vec3: without it the lambda returns an Eigen expression that refers to a Vec3
  // temporary dying with the lambda (k2 came out as garbage, ~1e-309).
  auto rel = [&](const Vec3& p) -> Vec3 {
    const Vec3 d = p - c.P[0];
    return Vec3(d.dot(f.u), d.dot(f.v), d.dot(f.w)) / f.s;
  };
  return RelativeTrajectory{rel(c.P[1]), rel(c.P[2]), c};
}

CubicBezier FromRelative(const RelativeTrajectory& r, const Vec3& p0, const Vec3& p3) {
  if (r.source && r.source->P[0] == p0 && r.source->P[3] == p3) return *r.source;
  const FoldFrame f = Frame(p0, p3);
  auto abs = [&](const Vec3& k) { return Vec3(p0 + f.s * (k.x() * f.u + k.y() * f.v + k.z() * f.w)); };
  return CubicBezier{{p0, abs(r.k1), abs(r.k2), p3}};
}

void PlanRunOptions::Validate() const {
  sim.Validate();
  optimise.Validate();
  key_points.Validate();
  flat_settle.Validate();
  if (!(camera_metres_per_pixel > 0 && camera_metres_per_pixel < 0.05))
    throw Error("PlanRunOptions.camera_metres_per_pixel must be in (0, 0.05)");
  if (!(thickness >= 0 && thickness < 0.05)) throw Error("PlanRunOptions.thickness must be in [0, 0.05) m");
}

Points3 SettleFlat(const FoldScene& scene, const Points3& laid, const SettleOptions& settle) {
  ClothWorld w(scene.model, laid);
  w.AddCollider(scene.table);
  const SettleReport r = w.Settle(settle);
  if (!r.settled && !r.timed_out) throw NumericalError("the garment laid on the table: " + r.failure);
  return w.positions();
}

namespace {

// The vertex a gripper takes for a grasp at world (x, z): the nearest in x–z, and among
// those within 5 mm of that distance the highest (the top layer, the one a gripper
// coming from above meets first).
int GraspVertex(const Points3& x, const Vec2& at) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < x.rows(); ++i) best = std::min(best, (Vec2(x(i, 0), x(i, 2)) - at).norm());
  int arg = -1;
  for (int i = 0; i < x.rows(); ++i)
    if ((Vec2(x(i, 0), x(i, 2)) - at).norm() <= best + 0.005 && (arg < 0 || x(i, 1) > x(arg, 1))) arg = i;
  return arg;
}

std::string StepWhere(const FoldingPlan& plan, const PlanStep& ps) {
  return plan.file_label + ":" + std::to_string(ps.line) + ": step '" + ps.name + "': ";
}

}  // namespace

PlanRun RunPlan(const FoldScene& scene, const Points3& laid, const std::string& category, const FoldingPlan& plan,
                const PlanRunOptions& o, const std::vector<std::vector<RelativeTrajectory>>* replay) {
  PlanRun run;
  RunPlan(run, scene, laid, category, plan, o, replay);
  return run;
}

std::vector<PlannedStep> PlanSteps(const TriMesh& flat, const std::map<std::string, Vec2>& key_points,
                                   const FoldingPlan& plan, double thickness) {
  // Plan points in world x, z: the picture's y (towards the collar) is world −z.
  auto resolve = [&](const PlanPoint& p) {
    Vec2 a = key_points.at(p.a);
    if (!p.b.empty()) a += p.t * (key_points.at(p.b) - a);
    return Vec2(a.x() + p.offset.x(), a.y() - p.offset.y());
  };
  std::vector<PlannedStep> out;
  TriMesh ideal = flat;
  const double reach = LongestEdge(flat);
  for (const PlanStep& ps : plan.steps) {
    PlannedStep st;
    st.name = ps.name;
    const Vec2 a = resolve(ps.line_from), b = resolve(ps.line_to);
    st.line = FoldLine{a, b - a};
    for (const PlanPoint& g : ps.grasps) {
      st.grasp_vertices.push_back(GraspVertex(flat.V, resolve(g)));
      st.grasps.push_back(g.b.empty() ? g.a : g.a + "~" + g.b);
    }
    try {
      const Vec3 g0 = ideal.V.row(st.grasp_vertices[0]).transpose();
      ideal = LandedFold(ideal, IdealFold(st.line, Vec2(g0.x(), g0.z()), ideal.V, thickness, reach));
    } catch (const Error& e) {
      throw Error(StepWhere(plan, ps) + e.what());
    }
    st.ideal = ideal;
    out.push_back(std::move(st));
  }
  return out;
}

void RunPlan(PlanRun& run, const FoldScene& scene, const Points3& laid, const std::string& category,
             const FoldingPlan& plan, const PlanRunOptions& o,
             const std::vector<std::vector<RelativeTrajectory>>* replay) {
  o.Validate();
  if (std::find(plan.categories.begin(), plan.categories.end(), category) == plan.categories.end())
    throw Error(plan.file_label + ": the plan '" + plan.name + "' is not for a " + category);
  if (replay && replay->size() != plan.steps.size()) throw Error("replay: one trajectory set per plan step");
  const Faces& F = scene.model->rest.F;
  run = PlanRun{};
  run.flat = SettleFlat(scene, laid, o.flat_settle);
  run.camera = tabletop::FrameCamera(run.flat, o.camera_metres_per_pixel, 0.05);
  const auto kp = DetectKeyPoints(tabletop::TopDownMask(TriMesh{run.flat, F}, run.camera), category, o.key_points);
  for (const auto& [name, f] : kp) run.key_points[name] = run.camera.ToWorldXZ(f);
  const std::vector<PlannedStep> planned = PlanSteps(TriMesh{run.flat, F}, run.key_points, plan, o.thickness);
  Points3 cur = run.flat;
  run.ideal = planned.empty() ? TriMesh{run.flat, F} : planned.back().ideal;
  for (size_t i = 0; i < plan.steps.size(); ++i) {
    const PlannedStep& pl = planned[i];
    const std::vector<int>& verts = pl.grasp_vertices;
    StepRecord rec;
    rec.name = pl.name;
    rec.line = pl.line;
    rec.grasps = pl.grasps;
    FoldSimOptions sim = o.sim;
    if (plan.steps[i].gripper) sim.gripper = *plan.steps[i].gripper;
    rec.gripper = sim.gripper;
    const std::string where = StepWhere(plan, plan.steps[i]);
    try {
      rec.setup = PrepareStep(scene, cur, rec.line, verts, o.thickness);
    } catch (const Error& e) {
      throw Error(where + e.what());
    }
    if (replay) {
      std::vector<CubicBezier> paths;
      const auto& rel = (*replay)[i];
      if (rel.size() != verts.size()) throw Error(where + "replay has the wrong number of arms");
      for (size_t k = 0; k < verts.size(); ++k) paths.push_back(FromRelative(rel[k], rec.setup.p0[k], rec.setup.p3[k]));
      rec.result.initial = rec.result.optimised = paths;
      rec.result.after = SimulateStep(scene, rec.setup, paths, sim, o.optimise.alpha, true);
      rec.result.before = rec.result.after;
    } else {
      try {
        rec.result = OptimiseStep(scene, rec.setup, sim, o.optimise);
      } catch (const NumericalError& e) {
        throw NumericalError(where + e.what());
      }
    }
    if (!rec.result.after.ok) throw NumericalError(where + rec.result.after.failure);
    for (const auto& c : rec.result.optimised) rec.relative.push_back(ToRelative(c));
    cur = rec.result.after.final;
    run.steps.push_back(std::move(rec));
    if (o.on_step) o.on_step(run.steps.back());
  }
  run.final = cur;
  run.final_dissimilarity = Dissimilarity(run.ideal, TriMesh{run.final, F});
}

}  // namespace drape::folding
