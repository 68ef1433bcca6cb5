// drape fold GARMENT --plan PLAN: the paper's trajectory optimisation for folding with
// the cloth simulation in the loop, and its evaluation over seeded, perturbed trials.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli/args.h"
#include "cli/command.h"
#include "common/error.h"
#include "common/files.h"
#include "common/format.h"
#include "common/json.h"
#include "garments/io.h"
#include "garments/templates.h"
#include "generator/hang/hang.h"
#include "generator/hang/material.h"
#include "runtime/folding/evaluate.h"
#include "runtime/folding/figures.h"

namespace drape::cli {
namespace {

using namespace drape::folding;
namespace fs = std::filesystem;

const char* kUsage =
    "Usage: drape fold GARMENT --plan PLAN [--trials N] [--seed S] [-o DIR]\n"
    "                  [--size S|M|L] [--edge M] [--material NAME] [--category C]\n"
    "                  [--gripper pinch|point] [--max-sims N] [--fan STEP|none] [--no-optimise]\n"
    "                  [--stiffness K] [--friction MU]\n"
    "\n"
    "Folds a garment lying flat on a table in simulation, step by step as PLAN says\n"
    "(runtime/folding/plans/*.yaml), optimising each step's cubic Bezier trajectories by\n"
    "secant Levenberg-Marquardt on C = l + 1000 D with the cloth simulation in the loop\n"
    "(paper: Trajectory Optimization for Folding); then replays the optimised trajectories\n"
    "in N seeded trials under perturbation (friction +-10 %, material +-10 %, placement\n"
    "offset <= 3 cm, yaw <= 5 deg) and reports the success rate.\n"
    "  GARMENT            a template name (towel, pants, shorts, long_sleeve_shirt, tshirt) or a\n"
    "                     flat garment mesh file (pattern frame, with its NAME.anchors.json)\n"
    "  --plan PATH        the folding plan\n"
    "  --trials N         evaluation trials (default 10; 0 = none)\n"
    "  --seed S           seed of the trials' perturbations (default 1)\n"
    "  -o, --output DIR   write trajectories.json, report.md and pictures (default fold-out)\n"
    "  --size S|M|L       template size (default M)\n"
    "  --edge M           mesh edge length, metres (default 0.04: coarse, simulation in the loop)\n"
    "  --material NAME    material preset (default by category: towel_b, pants, tshirt)\n"
    "  --category C       category of an imported mesh (default: its sidecar's)\n"
    "  --gripper MODEL    pinch (a gripper pinching a small area, default) or point (moving one vertex)\n"
    "  --max-sims N       simulations per step's optimisation (default 40)\n"
    "  --fan STEP|none    the solution-space fans for this step (1-based; default the last)\n"
    "  --no-optimise      keep the initial h = 1/3 trajectories (for comparison)\n"
    "  --stiffness K      Bullet link stiffness kLST instead of fitting it to the material's stretch\n"
    "  --friction MU      table friction coefficient instead of fitting it to the friction angle\n"
    "\n"
    "Material: link stiffness fitted to the measured stretch and table friction fitted to the\n"
    "measured friction angle (a square of the cloth starts to slide on a table tilted by it;\n"
    "generator/hang FitMaterial) unless --stiffness / --friction; strain limit 2 x the measured\n"
    "stretch.\n";

Garment LoadGarment(const std::string& what, const Args& args) {
  if (FindTemplate(what)) {
    TemplateOptions t;
    t.size = args.Get("--size", "M");
    t.edge_length = args.GetDouble("--edge").value_or(0.04);
    return MakeGarment(what, t);
  }
  if (!fs::exists(what)) throw Error("'" + what + "' is neither a garment template nor a mesh file");
  ImportOptions io;
  if (auto c = args.Get("--category")) io.category = *c;
  const fs::path anchors = AnchorsPath(what);
  return ImportGarment(what, fs::exists(anchors) ? anchors : fs::path(), io);
}

std::string DefaultMaterial(const std::string& category) {
  if (category == "towel") return "towel_b";
  if (category == "pants" || category == "shorts") return "pants";
  return "tshirt";
}

Json Vec(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }

Json PathsJson(const std::vector<CubicBezier>& paths) {
  Json a = Json::array();
  for (const auto& c : paths) a.push_back({{"P0", Vec(c.P[0])}, {"P1", Vec(c.P[1])}, {"P2", Vec(c.P[2])}, {"P3", Vec(c.P[3])}});
  return a;
}

Json SimJson(const StepSim& s) {
  return {{"ok", s.ok},          {"failure", s.failure},   {"length", s.length}, {"dissimilarity", s.dissimilarity},
          {"cost", s.cost},      {"settled", s.settled},   {"held_nodes", s.held}, {"sim_time", s.sim_time},
          {"wall_seconds", s.wall_seconds}};
}

void WritePng(const fs::path& p, const cv::Mat& img) {
  std::vector<uchar> buf;
  cv::imencode(".png", img, buf);
  WriteFileAtomic(p, std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

// The garment lying on the table, its material (link stiffness fitted to the measured
// stretch unless --stiffness) and the table's friction.
struct FoldInputs {
  FoldSetup setup;
  std::string material;
  MaterialFit fit;
};

FoldInputs SetUpFold(const Args& args) {
  FoldInputs in;
  FoldSetup& setup = in.setup;
  setup.garment = LoadGarment(args.positional()[0], args);
  in.material = args.Get("--material", DefaultMaterial(setup.garment.category));
  const Material* material = FindMaterialPreset(in.material);
  if (!material) throw Error("--material: unknown material '" + in.material + "'");
  // FitMaterial fits the link stiffness to the measured stretch and the table friction to
  // the measured friction angle (a square on a tilted table); skipped only when both are
  // given on the command line.
  const auto k = args.GetDouble("--stiffness");
  const auto mu = args.GetDouble("--friction");
  if (mu && !(*mu >= 0 && *mu < 5)) throw Error("--friction: must be in [0, 5), got " + FormatNumber(*mu));
  HangOptions ho;
  ho.fit_edge_length = args.GetDouble("--edge").value_or(0.04);
  if (!(k && mu)) {
    std::printf("fitting %s to its stretch (%.1f %%) and friction angle (%.1f deg) ...\n", in.material.c_str(),
                material->stretch_percent, material->friction_deg);
    std::fflush(stdout);
    in.fit = FitMaterial(*material, ho);
    std::printf("  kLST %.3f (reproduces %.2f %%), mu %.3f (slides at %.2f deg) in %.1f s\n", in.fit.stiffness,
                in.fit.reproduced_stretch_percent, in.fit.friction, in.fit.reproduced_friction_deg,
                in.fit.wall_seconds);
    std::fflush(stdout);
  }
  if (k) in.fit.stiffness = *k;
  if (mu) in.fit.friction = *mu;
  // The material and solver options the fit was made with (and the hangs use).
  setup.material = ClothMaterialFor(*material, in.fit, ho);
  setup.cloth = ClothOptionsFor(ho, ho.time_step);
  setup.friction = in.fit.friction;
  return in;
}

PlanRunOptions RunOptionsFrom(const Args& args, const FoldSetup& setup) {
  PlanRunOptions ro;
  ro.sim.gripper = ParseGripperModel(args.Get("--gripper", "pinch"));
  ro.thickness = setup.cloth.collision.thickness;
  if (auto n = args.GetInt("--max-sims")) ro.optimise.lm.max_residual_evaluations = static_cast<int>(*n);
  if (args.Flag("--no-optimise")) ro.optimise.lm.max_iterations = 0;
  ro.Validate();
  return ro;
}

// One step's record: trajectories before and after, costs, the other gripper's result.
Json StepJson(const StepRecord& s, const StepSim& alt, GripperModel other) {
  const StepOptimum& r = s.result;
  Json rel = Json::array();
  for (const auto& k : s.relative) rel.push_back({{"k1", Vec(k.k1)}, {"k2", Vec(k.k2)}});
  return {
      {"name", s.name},
      {"grasps", s.grasps},
      {"fold_line",
       {{"point", {s.line.point.x(), s.line.point.y()}}, {"direction", {s.line.direction.x(), s.line.direction.y()}}}},
      {"initial", PathsJson(r.initial)},
      {"optimised", PathsJson(r.optimised)},
      {"optimised_relative", rel},
      {"before", SimJson(r.before)},
      {"after", SimJson(r.after)},
      {"other_gripper", {{"model", GripperModelName(other)}, {"result", SimJson(alt)}}},
      {"optimiser",
       {{"simulations", r.simulations},
        {"iterations", r.lm.iterations},
        {"accepted", r.lm.accepted},
        {"rejected", r.lm.rejected},
        {"shortened", r.lm.shortened},
        {"evaluated_costs", r.evaluated},
        {"termination", r.lm.termination},
        {"cost_squared_half", r.lm.cost},
        {"wall_seconds", r.wall_seconds}}}};
}

// Trajectories, costs and key-frame pictures per step: the JSON steps, report rows in md.
Json ReportSteps(const FoldScene& scene, const PlanRun& run, const PlanRunOptions& ro, const Faces& F,
                 const fs::path& out, std::ostringstream& md) {
  Json steps = Json::array();
  // The other gripper model on the optimised trajectories: the paper's sim/real gap.
  FoldSimOptions other = ro.sim;
  other.gripper = ro.sim.gripper == GripperModel::kPinch ? GripperModel::kPoint : GripperModel::kPinch;
  for (size_t i = 0; i < run.steps.size(); ++i) {
    const StepRecord& s = run.steps[i];
    const StepOptimum& r = s.result;
    const StepSim alt = SimulateStep(scene, s.setup, r.optimised, other, ro.optimise.alpha);
    steps.push_back(StepJson(s, alt, other.gripper));
    char row[512];
    std::snprintf(row, sizeof row, "| %s | %zu | %.1f | %.1f | %.3f | %.3f | %.3f | %.3f | %d | %.0f |\n", s.name.c_str(),
                  s.grasps.size(), 1e3 * r.before.dissimilarity, 1e3 * r.after.dissimilarity, r.before.cost,
                  r.after.cost, r.before.length, r.after.length, r.simulations, r.wall_seconds);
    md << row;
    std::printf("step %zu %-16s D %.1f -> %.1f mm, C %.3f -> %.3f (%d simulations, %.0f s); %s gripper: D %.1f mm\n",
                i + 1, s.name.c_str(), 1e3 * r.before.dissimilarity, 1e3 * r.after.dissimilarity, r.before.cost,
                r.after.cost, r.simulations, r.wall_seconds, GripperModelName(other.gripper).c_str(),
                1e3 * alt.dissimilarity);
    std::fflush(stdout);
    // Key frames: the initial trajectory's run above the optimised one's.
    StepRecord initial = s;
    initial.result.after = r.before;
    cv::Mat pic;
    cv::vconcat(StepKeyFrames(initial, F), StepKeyFrames(s, F), pic);
    char name[64];
    std::snprintf(name, sizeof name, "step%zu_%s.png", i + 1, s.name.c_str());
    WritePng(out / name, pic);
  }
  return steps;
}

Json TrialJson(int t, const TrialResult& tr) {
  return {{"index", t},
          {"success", tr.success},
          {"failure", tr.failure},
          {"friction_scale", tr.friction_scale},
          {"stiffness_scale", tr.stiffness_scale},
          {"density_scale", tr.density_scale},
          {"offset", {tr.offset.x(), tr.offset.y()}},
          {"yaw_deg", tr.yaw_deg},
          {"final_dissimilarity", tr.final_dissimilarity},
          {"diagonal", tr.diagonal},
          {"inside_fraction", tr.inside_fraction},
          {"sim_time", tr.sim_time},
          {"wall_seconds", tr.wall_seconds}};
}

// Evaluation trials replaying the optimised relative trajectories under perturbation; a
// failed trial's last step as a picture; the success table in md.
Json RunTrials(const Args& args, const FoldSetup& setup, const FoldingPlan& plan, const PlanRunOptions& ro,
               const PlanRun& run, const fs::path& out, std::ostringstream& md) {
  std::vector<std::vector<RelativeTrajectory>> relative;
  for (const StepRecord& s : run.steps) relative.push_back(s.relative);
  TrialOptions to;
  to.trials = static_cast<int>(args.GetInt("--trials").value_or(10));
  to.seed = static_cast<uint64_t>(args.GetInt("--seed").value_or(1));
  int success = 0;
  double seconds = 0;
  Json trials = Json::array();
  for (int t = 0; t < to.trials; ++t) {
    const TrialResult tr = RunTrial(setup, plan, ro, relative, to, t);
    success += tr.success;
    seconds += tr.sim_time;
    trials.push_back(TrialJson(t, tr));
    std::printf("trial %d: %s, D %.1f mm (%.1f %% of %.2f m), silhouette %.0f %% inside\n", t,
                tr.success ? "success" : ("failed: " + tr.failure).c_str(), 1e3 * tr.final_dissimilarity,
                100 * tr.final_dissimilarity / std::max(tr.diagonal, 1e-9), tr.diagonal, 100 * tr.inside_fraction);
    std::fflush(stdout);
    if (!tr.success && !tr.run.steps.empty()) {
      cv::Mat pic = StepKeyFrames(tr.run.steps.back(), setup.garment.mesh.F);
      WritePng(out / ("failure_trial" + std::to_string(t) + ".png"), pic);
    }
  }
  if (to.trials > 0) {
    char row[256];
    md << "\n| garment | # folds | success | avg. simulated time (s) |\n|---|---|---|---|\n";
    std::snprintf(row, sizeof row, "| %s | %zu | %d/%d | %.1f |\n", setup.garment.instance.c_str(), plan.steps.size(),
                  success, to.trials, seconds / to.trials);
    md << row << "| paper (average, real robot) | 2.3 | 9.3/10 | 97 |\n\n"
       << "Success: D(ideal, final) <= " << to.d_fraction * 100 << " % of the flat garment's diagonal and >= "
       << to.inside * 100 << " % of the final silhouette inside the ideal one grown by " << to.silhouette_tolerance * 100
       << " cm.\n";
    std::printf("success %d/%d\n", success, to.trials);
  }
  return trials;
}

// The three 13-trajectory fans of step `fan` (1-based): fan.png, the D per knot height
// in md, and the same as JSON.
Json WriteFans(const FoldScene& scene, const PlanRun& run, const PlanRunOptions& ro, const std::string& fan,
               const fs::path& out, std::ostringstream& md) {
  const int k = std::stoi(fan) - 1;
  if (k < 0 || k >= static_cast<int>(run.steps.size())) throw Error("--fan: no step " + fan);
  std::vector<std::vector<FanTrajectory>> fans;
  for (const char* kind : {"symmetric", "early", "late"})
    fans.push_back(SolutionFan(scene, run.steps[k].setup, ro.sim, kind));
  const std::vector<std::string> kinds = {"symmetric", "first knot varies", "second knot varies"};
  WritePng(out / "fan.png", FanFigure(fans, kinds));
  // The numbers behind the picture: D per knot height h (× span) of the varied knots.
  md << "\nSolution-space fans for step " << k + 1 << " (fan.png), D (mm) per knot height h:\n\n| h |";
  for (const auto& kind : kinds) md << " " << kind << " |";
  md << "\n|---|---|---|---|\n";
  Json fan_json = Json::array();
  for (size_t t = 0; t < fans[0].size(); ++t) {
    const double h = fans[0][t].h;
    char row[128];
    std::snprintf(row, sizeof row, "| %.3f | %.1f | %.1f | %.1f |\n", h, 1e3 * fans[0][t].dissimilarity,
                  1e3 * fans[1][t].dissimilarity, 1e3 * fans[2][t].dissimilarity);
    md << row;
    fan_json.push_back({{"h", h},
                        {"symmetric", fans[0][t].dissimilarity},
                        {"first_knot", fans[1][t].dissimilarity},
                        {"second_knot", fans[2][t].dissimilarity}});
  }
  return {{"step", k + 1}, {"trajectories", fan_json}};
}

int Run(const std::vector<std::string>& argv) {
  Args args(argv, {"--no-optimise"},
            {"--plan", "--trials", "--seed", "-o", "--output", "--size", "--edge", "--material", "--category",
             "--gripper", "--max-sims", "--fan", "--stiffness", "--friction"});
  if (args.help()) {
    std::cout << kUsage;
    return 0;
  }
  args.RequirePositional(1, 1, "a GARMENT (template name or mesh file)");
  const auto plan_path = args.Get("--plan");
  if (!plan_path) throw Error("--plan PLAN is required");
  const FoldingPlan plan = LoadPlan(*plan_path);
  const fs::path out = args.Get("-o", args.Get("--output", "fold-out"));
  fs::create_directories(out);

  const FoldInputs in = SetUpFold(args);
  const FoldSetup& setup = in.setup;
  const std::string& category = setup.garment.category;
  const PlanRunOptions ro = RunOptionsFrom(args, setup);
  const FoldScene scene = MakeScene(setup);
  std::printf("%s: %d vertices, %d faces; plan %s, %zu steps, gripper %s\n", setup.garment.instance.c_str(),
              setup.garment.mesh.NumVertices(), setup.garment.mesh.NumFaces(), plan.name.c_str(), plan.steps.size(),
              GripperModelName(ro.sim.gripper).c_str());
  std::fflush(stdout);

  const PlanRun run = RunPlan(scene, LayFlat(setup.garment.mesh, setup.table), category, plan, ro);

  std::ostringstream md;
  md << "# drape fold: " << setup.garment.instance << " with plan " << plan.name << "\n\n"
     << "Mesh " << setup.garment.mesh.NumVertices() << " vertices / " << setup.garment.mesh.NumFaces()
     << " faces; material " << in.material << " (kLST " << in.fit.stiffness << ", mu " << setup.friction
     << "); gripper " << GripperModelName(ro.sim.gripper) << ".\n\n"
     << "| step | arms | D before (mm) | D after (mm) | C before | C after | l before (m) | l after (m) | simulations "
        "| "
        "seconds |\n|---|---|---|---|---|---|---|---|---|---|\n";
  const Json steps = ReportSteps(scene, run, ro, setup.garment.mesh.F, out, md);
  Json doc = {{"garment", setup.garment.instance},
              {"category", category},
              {"plan", plan.name},
              {"material", in.material},
              {"gripper", GripperModelName(ro.sim.gripper)},
              {"alpha", ro.optimise.alpha},
              {"delta", ro.optimise.lm.finite_difference_step},
              {"vertices", setup.garment.mesh.NumVertices()},
              {"final_dissimilarity", run.final_dissimilarity},
              {"steps", steps}};

  // The solution-space fans (paper Fig. "solution_space") for one step.
  const std::string fan = args.Get("--fan", std::to_string(plan.steps.size()));
  if (fan != "none") doc["fan"] = WriteFans(scene, run, ro, fan, out, md);

  doc["trials"] = RunTrials(args, setup, plan, ro, run, out, md);
  WriteFileAtomic(out / "trajectories.json", doc.dump(2) + "\n");
  WriteFileAtomic(out / "report.md", md.str());
  std::printf("wrote %s\n", out.string().c_str());
  return 0;
}

Register reg({"fold", "fold a garment on a table: optimised trajectories with the cloth simulation in the loop",
              kUsage, Run});

}  // namespace
}  // namespace drape::cli
