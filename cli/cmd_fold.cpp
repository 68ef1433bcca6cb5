// drape fold GARMENT --plan PLAN: the paper's trajectory optimisation for folding with
// the cloth simulation in the loop, and its evaluation over seeded, perturbed trials.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "cli/command.h"
#include "cli/config.h"
#include "cli/options.h"
#include "common/error.h"
#include "common/files.h"
#include "common/format.h"
#include "common/json.h"
#include "common/version.h"
#include "garments/io.h"
#include "garments/templates.h"
#include "generator/hang/hang.h"
#include "generator/hang/material.h"
#include "runtime/folding/evaluate.h"
#include "runtime/folding/figures.h"
#include "runtime/folding/placed.h"

namespace drape::cli {
namespace {

using namespace drape::folding;
namespace fs = std::filesystem;

const char* kFooter =
    "Folds a garment lying flat on a table in simulation, step by step as PLAN says\n"
    "(runtime/folding/plans/*.yaml), optimising each step's cubic Bezier trajectories by\n"
    "secant Levenberg-Marquardt on C = l + 1000 D with the cloth simulation in the loop\n"
    "(paper: Trajectory Optimization for Folding); then replays the optimised trajectories\n"
    "in N seeded trials under perturbation (friction +-10 %, material +-10 %, placement\n"
    "offset <= 3 cm, yaw <= 5 deg) and reports the success rate.\n"
    "GARMENT_OR_ENTRY: a template name (towel, pants, shorts, long_sleeve_shirt, tshirt), a\n"
    "flat garment mesh file (pattern frame, with its NAME.anchors.json), or a garment as\n"
    "drape unfold placed it: its trial folder (OUT/CATEGORY/trial_K), placed.json or\n"
    "trace.json; folded as it lies (turned upright), with the trial's material fit.\n"
    "Material: link stiffness fitted to the measured stretch and table friction fitted to the\n"
    "measured friction angle (a square of the cloth starts to slide on a table tilted by it;\n"
    "generator/hang FitMaterial); strain limit 1.8 x the measured stretch. Layers of the\n"
    "cloth on each other take the table's friction (no cloth-on-cloth angle is measured).\n"
    "The mesh edge, the optimisation budget, the fans and given material constants are the\n"
    "options file's `fold` section.";

// `fold`: the research settings of drape fold (mesh, optimisation budget, fans, material
// constants given instead of fitted).
struct FoldKnobs {
  double edge = 0.03;  // m: template mesh edge and the material fit's strip edge (docs/folding.md: 3 cm folds hold)
  int max_sims = 40;   // simulations per step's optimisation
  bool optimise = true;
  std::string fan = "last";    // the step whose solution-space fans are drawn: "last", "none" or 1-based
  double stiffness = 0;        // Bullet link stiffness kLST; 0: fitted to the stretch
  double friction = -1;        // table friction; < 0: fitted to the friction angle
  double cloth_friction = -1;  // between layers of the cloth; < 0: the table's
  void Validate() const {
    if (!(edge >= 0.005 && edge <= 0.2)) BadField(edge, "edge", "must be in [0.005, 0.2] m, got " + FormatNumber(edge));
    if (max_sims < 1) BadField(max_sims, "max_sims", "must be >= 1, got " + std::to_string(max_sims));
    if (!(stiffness >= 0 && stiffness <= 1))
      BadField(stiffness, "stiffness", "must be in (0, 1] (0: fitted), got " + FormatNumber(stiffness));
    if (!(friction == -1 || (friction >= 0 && friction < 5)))
      BadField(friction, "friction", "must be in [0, 5) (-1: fitted), got " + FormatNumber(friction));
    if (!(cloth_friction == -1 || (cloth_friction >= 0 && cloth_friction < 5)))
      BadField(cloth_friction, "cloth_friction",
               "must be in [0, 5) (-1: the table's), got " + FormatNumber(cloth_friction));
    if (fan != "last" && fan != "none" && FanStep() < 1)
      BadField(fan, "fan", "'" + fan + "' is not last, none or a step number (1-based)");
  }
  // The fan's step as a number (0 when not a positive integer).
  int FanStep() const {
    int k = 0;
    const auto r = std::from_chars(fan.data(), fan.data() + fan.size(), k);
    return r.ec == std::errc() && r.ptr == fan.data() + fan.size() && k > 0 ? k : 0;
  }
};

const ConfigSection<FoldKnobs> kFoldSection(
    "fold", "`drape fold`'s mesh, optimisation budget, solution-space fans and material constants (docs/folding.md).",
    {{"edge", Ref(&FoldKnobs::edge), "m", "mesh edge length of a template (and of the material fit's strip)"},
     {"max_sims", Ref(&FoldKnobs::max_sims), "simulations", "simulations per step's optimisation"},
     {"optimise", Ref(&FoldKnobs::optimise), "bool", "optimise (false: keep the initial h = 1/3 trajectories)"},
     {"fan", Ref(&FoldKnobs::fan), "step",
      "the step whose solution-space fans are drawn: `last`, `none` or its number"},
     {"stiffness", Ref(&FoldKnobs::stiffness), "—", "Bullet link stiffness kLST instead of the fitted (0: fitted)"},
     {"friction", Ref(&FoldKnobs::friction), "—", "table friction coefficient instead of the fitted (-1: fitted)"},
     {"cloth_friction", Ref(&FoldKnobs::cloth_friction), "—",
      "Coulomb friction between layers of the cloth (-1: the table's)"}});

struct FoldArgs {
  std::string garment, plan, output = "fold-out", size = "M", material, category, gripper = "pinch", replay, config;
  int trials = 10;
  uint64_t seed = 1;
  bool key_points_only = false;
  FoldKnobs knobs;  // from --config
};

Garment LoadGarment(const std::string& what, const FoldArgs& args) {
  if (FindTemplate(what)) {
    TemplateOptions t;
    t.size = args.size;
    t.edge_length = args.knobs.edge;
    return MakeGarment(what, t);
  }
  if (!fs::exists(what)) throw Error("'" + what + "' is neither a garment template nor a mesh file");
  ImportOptions io;
  if (!args.category.empty()) io.category = args.category;
  const fs::path anchors = AnchorsPath(what);
  return ImportGarment(what, fs::exists(anchors) ? anchors : fs::path(), io);
}

std::string DefaultMaterial(const std::string& category) {
  if (category == "towel") return "towel_b";
  if (category == "pants" || category == "shorts") return "pants";
  if (category == "long_sleeve_shirt") return "shirting";  // a dress shirt: woven cotton, creases
  return "tshirt";
}

Json Vec(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }

Json PathsJson(const std::vector<CubicBezier>& paths) {
  Json a = Json::array();
  for (const auto& c : paths)
    a.push_back({{"P0", Vec(c.P[0])}, {"P1", Vec(c.P[1])}, {"P2", Vec(c.P[2])}, {"P3", Vec(c.P[3])}});
  return a;
}

Json SimJson(const StepSim& s) {
  return {{"ok", s.ok},
          {"failure", s.failure},
          {"length", s.length},
          {"dissimilarity", s.dissimilarity},
          {"cost", s.cost},
          {"settled", s.settled},
          {"held_nodes", s.held},
          {"sim_time", s.sim_time},
          {"time_step", s.time_step},
          {"wall_seconds", s.wall_seconds}};
}

void WritePng(const fs::path& p, const cv::Mat& img) {
  std::vector<uchar> buf;
  cv::imencode(".png", img, buf);
  WriteFileAtomic(p, std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

// The garment lying on the table, its material (link stiffness fitted to the measured
// stretch unless given) and the table's friction.
struct FoldInputs {
  FoldSetup setup;
  std::string material;
  MaterialFit fit;
};

FoldInputs SetUpFold(const FoldArgs& args) {
  FoldInputs in;
  FoldSetup& setup = in.setup;
  const std::string& what = args.garment;
  std::optional<PlacedGarment> placed;
  if (!FindTemplate(what) && IsPlacedGarmentPath(what)) {
    placed = ReadPlacedGarment(what);
    setup.garment = std::move(placed->garment);
    setup.lying = std::move(placed->lying);
  } else {
    setup.garment = LoadGarment(what, args);
  }
  const bool preset = placed && FindMaterialPreset(placed->material);
  in.material = !args.material.empty() ? args.material
                : preset               ? placed->material
                                       : DefaultMaterial(setup.garment.category);
  const Material* material = FindMaterialPreset(in.material);
  if (!material) throw Error("--material: unknown material '" + in.material + "'");
  // FitMaterial fits the link stiffness to the measured stretch and the table friction to
  // the measured friction angle (a square on a tilted table); skipped only when both are
  // given in the options file.
  // A placed garment keeps the fit its unfold trial's cloth had (at its mesh's edges).
  std::optional<double> k, mu;
  if (args.knobs.stiffness > 0) k = args.knobs.stiffness;
  if (args.knobs.friction >= 0) mu = args.knobs.friction;
  if (placed && !k) k = placed->stiffness;
  if (placed && !mu) mu = placed->friction;
  HangOptions ho;
  ho.fit_edge_length = args.knobs.edge;
  // The stretch reference strip (fit_width 0.1 m) is hung from its top_centre node, node
  // nx/2 of nx = round(width / edge) elements across: at 8 cm edges nx = 1 and that node
  // is a corner — the strip hangs from its corner, swings diagonal, and what FitMaterial
  // measures is not the stretch (the fit ran to its kLST floor 0.001). Keep an even
  // number (≥ 2) of whole elements across, so the node is the middle of the top edge.
  const int across = std::max(2, 2 * static_cast<int>(std::lround(ho.fit_width / (2 * ho.fit_edge_length))));
  ho.fit_width = across * ho.fit_edge_length;
  if (!(k && mu)) {
    std::printf("fitting %s to its stretch (%.1f %%) and friction angle (%.1f deg) ...\n", in.material.c_str(),
                material->stretch_percent, material->friction_deg);
    std::fflush(stdout);
    in.fit = FitMaterial(*material, ho);
    std::printf("  kLST %.3f (reproduces %.2f %%), mu %.3f (slides at %.2f deg) in %.1f s\n", in.fit.stiffness,
                in.fit.reproduced_stretch_percent, in.fit.friction, in.fit.reproduced_friction_deg,
                in.fit.wall_seconds);
    if (material->bending_rigidity > 0)  // hinge bending: the constant the cantilever fitted, and how well
      std::printf("  hinge constant %.2f (bending length %.2f cm, target %.2f)%s\n", in.fit.bending_scale,
                  100 * in.fit.reproduced_bending_length, 100 * in.fit.target_bending_length,
                  in.fit.converged ? "" : "; the fit did not converge");
    if (material->crease_recovery_deg > 0)  // creases: the yield the crease test fitted
      std::printf("  crease yield %.1f 1/m (the crease test opens to %.1f deg, measured %.1f)\n", in.fit.crease_yield,
                  in.fit.reproduced_crease_recovery_deg, material->crease_recovery_deg);
    std::fflush(stdout);
  }
  if (k) in.fit.stiffness = *k;
  if (mu) in.fit.friction = *mu;
  // The material and solver options the fit was made with (and the hangs use).
  setup.material = ClothMaterialFor(*material, in.fit, ho);
  setup.cloth = ClothOptionsFor(ho, ho.time_step);
  setup.friction = in.fit.friction;
  // Cloth on cloth: the hang leaves it frictionless, but a fold stacks layers that must
  // not slide off each other. No cloth-on-cloth angle was measured, so the table's
  // fitted μ (the paper's table was measured with garments on it) unless given.
  setup.cloth.collision.cloth_friction = args.knobs.cloth_friction >= 0 ? args.knobs.cloth_friction : in.fit.friction;
  return in;
}

PlanRunOptions RunOptionsFrom(const FoldArgs& args, const FoldSetup& setup) {
  PlanRunOptions ro;
  ro.sim.gripper = ParseGripperModel(args.gripper);
  ro.thickness = setup.cloth.collision.thickness;
  ro.optimise.lm.max_residual_evaluations = args.knobs.max_sims;
  if (!args.knobs.optimise) ro.optimise.lm.max_iterations = 0;
  ro.Validate();
  return ro;
}

// The optimising run says each step as it finishes (the trials' replays stay quiet).
PlanRunOptions WithProgress(PlanRunOptions ro) {
  ro.on_step = [](const StepRecord& s) {
    const StepOptimum& r = s.result;
    std::printf("  %-16s D %.1f -> %.1f mm, C %.3f -> %.3f (%d simulations, %.0f s)\n", s.name.c_str(),
                1e3 * r.before.dissimilarity, 1e3 * r.after.dissimilarity, r.before.cost, r.after.cost, r.simulations,
                r.wall_seconds);
    std::fflush(stdout);
  };
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
      {"gripper", GripperModelName(s.gripper)},
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
  for (size_t i = 0; i < run.steps.size(); ++i) {
    const StepRecord& s = run.steps[i];
    const StepOptimum& r = s.result;
    // The other gripper model on the optimised trajectories: the paper's sim/real gap.
    FoldSimOptions other = ro.sim;
    other.gripper = s.gripper == GripperModel::kPinch ? GripperModel::kPoint : GripperModel::kPinch;
    const StepSim alt = SimulateStep(scene, s.setup, r.optimised, other, ro.optimise.alpha);
    steps.push_back(StepJson(s, alt, other.gripper));
    char row[512];
    std::snprintf(row, sizeof row, "| %s | %zu | %s | %.1f | %.1f | %.3f | %.3f | %.3f | %.3f | %d | %.0f |\n",
                  s.name.c_str(), s.grasps.size(), GripperModelName(s.gripper).c_str(), 1e3 * r.before.dissimilarity,
                  1e3 * r.after.dissimilarity, r.before.cost, r.after.cost, r.before.length, r.after.length,
                  r.simulations, r.wall_seconds);
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
          {"completed", tr.completed},
          {"failure", tr.failure},
          {"friction_scale", tr.friction_scale},
          {"stiffness_scale", tr.stiffness_scale},
          {"density_scale", tr.density_scale},
          {"offset", {tr.offset.x(), tr.offset.y()}},
          {"yaw_deg", tr.yaw_deg},
          {"final_dissimilarity", tr.final_dissimilarity},
          {"diagonal", tr.diagonal},
          {"inside_fraction", tr.inside_fraction},
          {"silhouette_reach", tr.reach},
          {"sim_time", tr.sim_time},
          {"wall_seconds", tr.wall_seconds}};
}

// One row of the trials table in md.
std::string TrialRow(const std::string& label, const TrialResult& tr) {
  char row[512];
  if (!tr.completed) {
    std::snprintf(row, sizeof row,
                  "| %s | %.3f | %.3f | %.3f | (%.3f, %.3f) | %.1f | – | – | – | – | did not finish: %s |\n",
                  label.c_str(), tr.friction_scale, tr.stiffness_scale, tr.density_scale, tr.offset.x(), tr.offset.y(),
                  tr.yaw_deg, tr.failure.c_str());
  } else {
    std::snprintf(row, sizeof row,
                  "| %s | %.3f | %.3f | %.3f | (%.3f, %.3f) | %.1f | %.1f | %.1f | %.0f | %.1f | %s |\n", label.c_str(),
                  tr.friction_scale, tr.stiffness_scale, tr.density_scale, tr.offset.x(), tr.offset.y(), tr.yaw_deg,
                  1e3 * tr.final_dissimilarity, 100 * tr.final_dissimilarity / std::max(tr.diagonal, 1e-9),
                  100 * tr.inside_fraction, 100 * tr.reach, tr.success ? "success" : tr.failure.c_str());
  }
  return row;
}

void PrintTrial(const std::string& label, const TrialResult& tr) {
  if (!tr.completed)
    std::printf("%s: did not finish: %s\n", label.c_str(), tr.failure.c_str());
  else
    std::printf("%s: %s, D %.1f mm (%.1f %% of %.2f m), silhouette %.0f %% inside (reach %.1f cm)\n", label.c_str(),
                tr.success ? "success" : ("failed: " + tr.failure).c_str(), 1e3 * tr.final_dissimilarity,
                100 * tr.final_dissimilarity / std::max(tr.diagonal, 1e-9), tr.diagonal, 100 * tr.inside_fraction,
                100 * tr.reach);
  std::fflush(stdout);
}

// The picture of a failed trial: its last finished step's key frames, or the flat
// garment with the key points found when it stopped before the first fold.
void WriteFailurePicture(const fs::path& file, const TrialResult& tr, const Faces& F, double tolerance) {
  if (tr.completed) {
    const cv::Mat steps = StepKeyFrames(tr.run.steps.back(), F);
    cv::Mat judged = ResultFigure(tr.run, F, tolerance, tr.failure), pic;
    // The judged result beside the last step's frames, padded to the same height.
    if (judged.rows < steps.rows)
      cv::copyMakeBorder(judged, judged, 0, steps.rows - judged.rows, 0, 0, cv::BORDER_CONSTANT, cv::Scalar::all(255));
    if (judged.rows > steps.rows)
      cv::resize(judged, judged, cv::Size(judged.cols * steps.rows / judged.rows, steps.rows));
    cv::hconcat(steps, judged, pic);
    WritePng(file, pic);
  } else if (!tr.run.steps.empty()) {
    WritePng(file, StepKeyFrames(tr.run.steps.back(), F));
  } else if (tr.run.flat.rows() > 0) {
    WritePng(file, FlatGarmentFigure(tr.run, F, tr.failure));
  }
}

// Evaluation trials replaying the optimised relative trajectories under perturbation,
// after the criterion applied to the unperturbed run itself; a failed trial as a
// picture; the success table and one row per trial in md.
Json RunTrialsReport(const FoldArgs& args, const FoldSetup& setup, const FoldingPlan& plan, const PlanRunOptions& ro,
                     const PlanRun& run, const fs::path& out, std::ostringstream& md, Json& nominal_json) {
  std::vector<std::vector<RelativeTrajectory>> relative;
  for (const StepRecord& s : run.steps) relative.push_back(s.relative);
  TrialOptions to;
  to.trials = args.trials;
  to.seed = args.seed;
  const Faces& F = setup.garment.mesh.F;
  TrialResult nominal;
  nominal.index = -1;
  nominal.run = run;
  nominal.completed = true;
  JudgeFold(nominal, F, to);
  nominal_json = TrialJson(-1, nominal);
  PrintTrial("unperturbed", nominal);
  WritePng(out / "result.png",
           ResultFigure(run, F, to.silhouette_tolerance,
                        nominal.success ? "unperturbed: success" : "unperturbed: " + nominal.failure));
  md << "\n| trial | friction × | stiffness × | density × | offset (m) | yaw (°) | D (mm) | D (% of diagonal) "
        "| silhouette inside (%) | reach (cm) | result |\n|---|---|---|---|---|---|---|---|---|---|---|\n"
     << TrialRow("unperturbed", nominal);
  int success = 0;
  double seconds = 0;
  Json trials = Json::array();
  RunTrials(setup, plan, ro, relative, to, [&](const TrialResult& tr) {
    success += tr.success;
    seconds += tr.sim_time;
    trials.push_back(TrialJson(tr.index, tr));
    md << TrialRow(std::to_string(tr.index), tr);
    PrintTrial("trial " + std::to_string(tr.index), tr);
    if (!tr.success)
      WriteFailurePicture(out / ("failure_trial" + std::to_string(tr.index) + ".png"), tr, F, to.silhouette_tolerance);
  });
  if (to.trials > 0) {
    char row[256];
    md << "\n| garment | # folds | success | avg. simulated time (s) |\n|---|---|---|---|\n";
    std::snprintf(row, sizeof row, "| %s | %zu | %d/%d | %.1f |\n", setup.garment.instance.c_str(), plan.steps.size(),
                  success, to.trials, seconds / to.trials);
    md << row << "| paper (average, real robot) | 2.3 | 9.3/10 | 97 |\n\n"
       << "Success: D(ideal, final) <= " << to.d_fraction * 100
       << " % of the flat garment's diagonal and >= " << to.inside * 100
       << " % of the final silhouette inside the ideal one grown by " << to.silhouette_tolerance * 100
       << " cm (reach: the distance from the ideal silhouette within which " << to.inside * 100
       << " % of the final one lies).\n";
    std::printf("success %d/%d\n", success, to.trials);
  }
  return trials;
}

// The optimised trajectories of an earlier run (its trajectories.json), one set per
// plan step, relative to each step's P0 -> P3.
std::vector<std::vector<RelativeTrajectory>> LoadReplay(const fs::path& file, const FoldingPlan& plan) {
  Json doc;
  try {
    doc = Json::parse(ReadFile(file));
  } catch (const Json::exception& e) {
    throw Error(file.string() + ": " + e.what());
  }
  auto v3 = [&](const Json& a) {
    if (!a.is_array() || a.size() != 3) throw Error(file.string() + ": a knot is not [x, y, z]");
    return Vec3(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
  };
  if (doc.value("plan", "") != plan.name)
    throw Error(file.string() + ": made with plan '" + doc.value("plan", "") + "', not '" + plan.name + "'");
  if (!doc.contains("steps") || !doc["steps"].is_array()) throw Error(file.string() + ": no steps array");
  const Json& steps = doc["steps"];
  if (steps.size() != plan.steps.size())
    throw Error(file.string() + ": " + std::to_string(steps.size()) + " steps, the plan has " +
                std::to_string(plan.steps.size()));
  std::vector<std::vector<RelativeTrajectory>> out;
  try {
    for (const Json& st : steps) {
      out.emplace_back();
      for (const Json& k : st.at("optimised_relative"))
        out.back().push_back({v3(k.at("k1")), v3(k.at("k2")), std::nullopt});
      // The absolute paths too (JSON keeps a double exactly): on the run's own garment
      // the replay then takes them as they were (RelativeTrajectory::source).
      const Json& abs = st.value("optimised", Json::array());
      if (abs.size() != out.back().size()) continue;
      for (size_t a = 0; a < abs.size(); ++a)
        out.back()[a].source =
            CubicBezier{{v3(abs[a].at("P0")), v3(abs[a].at("P1")), v3(abs[a].at("P2")), v3(abs[a].at("P3"))}};
    }
  } catch (const Json::exception& e) {
    throw Error(file.string() + ": steps[" + std::to_string(out.size() - 1) + "].optimised_relative: " + e.what());
  }
  return out;
}

// The three 13-trajectory fans of step `fan` (1-based): fan.png, the D per knot height
// in md, and the same as JSON.
Json WriteFans(const FoldScene& scene, const PlanRun& run, const PlanRunOptions& ro, int fan, const fs::path& out,
               std::ostringstream& md) {
  const int k = fan - 1;
  FoldSimOptions sim = ro.sim;
  sim.gripper = run.steps[k].gripper;
  std::vector<std::vector<FanTrajectory>> fans;
  for (const char* kind : {"symmetric", "early", "late"})
    fans.push_back(SolutionFan(scene, run.steps[k].setup, sim, kind));
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

// The run's gripper, or per step when a plan step names its own: "pinch" or
// "point, point, pinch, pinch, pinch (per step)".
std::string GrippersLabel(const FoldingPlan& plan, GripperModel fallback) {
  std::string per_step;
  bool any = false;
  for (const PlanStep& s : plan.steps) {
    any = any || s.gripper.has_value();
    per_step += (per_step.empty() ? "" : ", ") + GripperModelName(s.gripper.value_or(fallback));
  }
  return any ? per_step + " (per step)" : GripperModelName(fallback);
}

// --key-points-only: each trial's perturbed garment settles flat and the camera looks
// for the plan's key points (the plan without its steps: no folding simulated).
int KeyPointTrials(const FoldArgs& args, const FoldSetup& setup, const FoldingPlan& plan, const PlanRunOptions& ro,
                   const fs::path& out) {
  FoldingPlan none = plan;
  none.steps.clear();
  TrialOptions to;
  to.trials = args.trials;
  to.seed = args.seed;
  int found = 0;
  RunTrials(setup, none, ro, {}, to, [&](const TrialResult& tr) {
    found += tr.completed;
    char caption[256];
    std::snprintf(caption, sizeof caption,
                  "trial %d: friction x%.3f, stiffness x%.3f, offset (%.3f, %.3f) m, yaw %.1f deg", tr.index,
                  tr.friction_scale, tr.stiffness_scale, tr.offset.x(), tr.offset.y(), tr.yaw_deg);
    std::printf("%s: %s\n", caption, tr.completed ? "key points found" : tr.failure.c_str());
    std::fflush(stdout);
    if (tr.run.flat.rows() > 0)
      WritePng(out / ("keypoints_trial" + std::to_string(tr.index) + ".png"),
               FlatGarmentFigure(tr.run, setup.garment.mesh.F, tr.completed ? caption : tr.failure));
  });
  std::printf("key points found in %d/%d trials\n", found, to.trials);
  return 0;
}

int Run(FoldArgs& args) {
  kFoldSection.Read(OptionsFile::LoadIfGiven(args.config), args.knobs);
  const FoldingPlan plan = LoadPlan(args.plan);
  // The fans' step, checked before the expensive part.
  const int fan = args.knobs.fan == "none"   ? 0
                  : args.knobs.fan == "last" ? static_cast<int>(plan.steps.size())
                                             : args.knobs.FanStep();
  if (fan > static_cast<int>(plan.steps.size()))
    throw Error("fold.fan: no step " + args.knobs.fan + " (plan " + plan.name + " has " +
                std::to_string(plan.steps.size()) + ")");
  const fs::path out = args.output;
  fs::create_directories(out);

  const FoldInputs in = SetUpFold(args);
  const FoldSetup& setup = in.setup;
  const std::string& category = setup.garment.category;
  const PlanRunOptions ro = RunOptionsFrom(args, setup);
  const FoldScene scene = MakeScene(setup);
  const std::string grippers = GrippersLabel(plan, ro.sim.gripper);
  std::printf("%s: %d vertices, %d faces; plan %s, %zu steps, gripper %s\n", setup.garment.instance.c_str(),
              setup.garment.mesh.NumVertices(), setup.garment.mesh.NumFaces(), plan.name.c_str(), plan.steps.size(),
              grippers.c_str());
  std::fflush(stdout);

  if (args.key_points_only) return KeyPointTrials(args, setup, plan, ro, out);
  std::vector<std::vector<RelativeTrajectory>> replay;
  if (!args.replay.empty()) replay = LoadReplay(args.replay, plan);
  PlanRun run;
  try {
    RunPlan(run, scene, LaidGarment(setup), category, plan, WithProgress(ro), replay.empty() ? nullptr : &replay);
  } catch (const NumericalError& e) {
    // A simulation that cannot run (a gripper that catches no cloth, a blow-up) ends the
    // run with its step named, as a failure of this input rather than of drape.
    throw Error(std::string("the simulation failed: ") + e.what());
  }

  std::ostringstream md;
  md << "# drape fold: " << setup.garment.instance << " with plan " << plan.name << "\n\n"
     << "Mesh " << setup.garment.mesh.NumVertices() << " vertices / " << setup.garment.mesh.NumFaces()
     << " faces; material " << in.material << " (kLST " << in.fit.stiffness << ", mu " << setup.friction
     << "); gripper " << grippers << "." << (replay.empty() ? "" : " Replayed " + args.replay + " (no optimisation).")
     << "\n\n"
     << "| step | arms | gripper | D before (mm) | D after (mm) | C before | C after | l before (m) | l after (m) "
        "| simulations | seconds |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  const Json steps = ReportSteps(scene, run, ro, setup.garment.mesh.F, out, md);
  Json doc = {{"garment", setup.garment.instance},
              {"category", category},
              {"plan", plan.name},
              {"material", in.material},
              {"gripper", GripperModelName(ro.sim.gripper)},  // the default; each step says its own
              {"alpha", ro.optimise.alpha},
              {"delta", ro.optimise.lm.finite_difference_step},
              {"vertices", setup.garment.mesh.NumVertices()},
              {"final_dissimilarity", run.final_dissimilarity},
              {"steps", steps},
              {"provenance", RunProvenance()}};

  // The solution-space fans (paper Fig. "solution_space") for one step.
  if (fan > 0) doc["fan"] = WriteFans(scene, run, ro, fan, out, md);

  // Written before the trials too: the optimisation is the expensive part.
  WriteFileAtomic(out / "trajectories.json", doc.dump(2) + "\n");
  WriteFileAtomic(out / "report.md", md.str());
  Json nominal;
  doc["trials"] = RunTrialsReport(args, setup, plan, ro, run, out, md, nominal);
  doc["unperturbed"] = nominal;
  WriteFileAtomic(out / "trajectories.json", doc.dump(2) + "\n");
  WriteFileAtomic(out / "report.md", md.str());
  std::printf("wrote %s\n", out.string().c_str());
  return 0;
}

Runner Setup(CLI::App& app) {
  auto a = std::make_shared<FoldArgs>();
  app.footer(kFooter);
  app.add_option("GARMENT_OR_ENTRY", a->garment, "a template name, a flat garment mesh or an unfold trial's folder")
      ->required();
  app.add_option("--plan", a->plan, "the folding plan (runtime/folding/plans/*.yaml)")->type_name("PATH")->required();
  AddCount(app, "--trials", a->trials, "evaluation trials (0: none)", 0);
  AddSeed(app, a->seed, "seed of the trials' perturbations");
  AddOutput(app, a->output, "write trajectories.json, report.md and pictures here")->capture_default_str();
  app.add_option("--size", a->size, "template size")->check(CLI::IsMember({"S", "M", "L"}))->capture_default_str();
  app.add_option("--material", a->material,
                 "material preset (default by category: towel_b, pants, shirting for the long-sleeve shirt, tshirt)")
      ->type_name("NAME");
  app.add_option("--category", a->category, "category of an imported mesh (default: its sidecar's)")->type_name("C");
  app.add_option("--gripper", a->gripper,
                 "pinch (a small area) or point (one vertex), for the plan steps that do not name their gripper")
      ->check(CLI::IsMember({"pinch", "point"}))
      ->capture_default_str();
  app.add_option("--replay", a->replay,
                 "no optimisation: replay an earlier run's trajectories.json (relative to each step's P0 -> P3)")
      ->type_name("FILE");
  app.add_flag("--key-points-only", a->key_points_only,
               "no folding: the trials' perturbed flat garments and the key points the camera finds on them");
  AddConfig(app, a->config);
  return [a] { return Run(*a); };
}

Register reg({"fold", "fold a garment on a table: optimised trajectories with the cloth simulation in the loop",
              Setup});

}  // namespace
}  // namespace drape::cli
