// drape unfold: the regrasping/unfolding loop (paper §"Online Model Registration for
// Regrasping and Unfolding") on simulated dual-arm hardware, trials and the paper's table.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <mutex>

#include "cli/command.h"
#include "cli/config.h"
#include "cli/options.h"
#include "common/error.h"
#include "common/files.h"
#include "common/parallel.h"
#include "common/rng.h"
#include "common/version.h"
#include "garments/io.h"
#include "garments/templates.h"
#include "runtime/folding/placed.h"
#include "runtime/recognition/release_source.h"
#include "runtime/unfolding/figures.h"
#include "runtime/unfolding/loop.h"
#include "runtime/unfolding/report.h"

namespace drape::cli {
namespace {

namespace fs = std::filesystem;
using namespace drape::unfolding;

const char* kFooter =
    "Unfolds test garments of the release with simulated dual-arm hardware (paper Algorithm\n"
    "\"Iterative Procedure for Regrasping\"): pick up at a random point, turn in front of the\n"
    "Kinect, fuse, recognise the grasped anchor (learned weights), register the matched\n"
    "database mesh, choose the next grasp by the objective f over anchor pairs (Eq. finalobj),\n"
    "refine it with the IR range sensor (LoG), regrasp with the free arm; until f >= xi; then\n"
    "lay the garment flat on the table (drape fold OUT/<category>/trial_<k> --plan PLAN folds\n"
    "it as it lies). Desired pairs: long_sleeve_shirt both elbows, pants/shorts the outer\n"
    "leg-opening corners, towel two adjacent corners. The loop's settings (Kinect frames,\n"
    "regrasps, candidates, plan prior, the single ablations, placing) are the options file's\n"
    "`unfold` section.";

// `unfold`: the loop's research settings (runtime/unfolding/loop.h; each struct's
// Validate() owns the ranges, so a bad value is reported at its key).
const ConfigSection<LoopOptions> kUnfoldSection(
    "unfold",
    "`drape unfold`'s loop (runtime/unfolding/loop.h, docs/unfolding.md): sensing, recognition, the next grasp, the "
    "regrasp and the placing.",
    {{"frames", Ref(&LoopOptions::observe, &ObserveOptions::capture, &hardware::CaptureOptions::frames), "frames",
      "Kinect frames per turn, 360° one way and back (the paper's 550)"},
     {"max_regrasps", Ref(&LoopOptions::max_regrasps), "", "give up after this many regrasps"},
     {"category_known", Ref(&LoopOptions::recognise, &RecogniseOptions::category_known), "bool",
      "tell recognition the category (false: by registration at every hang, the fits summed over the hangs)"},
     {"refit_absent_penalty", Ref(&LoopOptions::recognise, &RecogniseOptions::refit_absent_penalty), "—",
      "at every hang, a category left out of the hang's registration counts the hang's worst score + this"},
     {"plan_prior_top_k", Ref(&LoopOptions::recognise, &RecogniseOptions::plan_prior_top_k), "anchors",
      "after a regrasp keep the anchor it aimed at (or its twin) when recognition ranks it in its top k, else as "
      "that anchor's best entry"},
     {"candidates", Ref(&LoopOptions::plan, &PlanOptions::candidates), "entries",
      "register recognition's top k database entries and predict from the best rigid fit (1: its answer alone)"},
     {"lowest_near_radius", Ref(&LoopOptions::plan, &PlanOptions::lowest, &LowestPointOptions::near_radius), "m",
      "regrasp at the reconstruction's lowest point within this distance of the registered target when the target "
      "is the hang's lowest near it (0: off)"},
     {"xi", Ref(&LoopOptions::plan, &PlanOptions::objective, &ObjectiveOptions::xi), "—",
      "ξ: stop regrasping when f ≥ ξ"},
     {"ir_refinement", Ref(&LoopOptions::regrasp, &RegraspOptions::ir_refinement), "bool",
      "refine the grasp point with the IR scan (false: the \"no IR refinement\" ablation alone)"},
     {"nonrigid", Ref(&LoopOptions::plan, &PlanOptions::nonrigid), "bool",
      "non-rigid registration after the rigid (false: the \"rigid-only registration\" ablation alone)"},
     {"verify", Ref(&LoopOptions::verify), "bool",
      "declare f ≥ ξ only when the hang just sensed supports the held anchor (in recognition's top k) and the "
      "category (its registration); false: on the belief, as the paper"},
     {"place_flat", Ref(&LoopOptions::place_flat), "bool",
      "lay the garment flat once f ≥ ξ (success is judged before; the placing is a long cloth simulation)"}});

struct UnfoldArgs {
  std::string release, category, output, weights, config;
  std::vector<int> only;  // --only, 1-based as given
  int trials = 10, jobs = 1;
  uint64_t seed = 1;
  bool ablations = false, no_figures = false, dump_meshes = false;
};

struct Variant {
  std::string name;
  bool ir = true, nonrigid = true, weighted = true;
};

// --category, checked before anything expensive: a known category with a desired pair.
std::vector<std::string> RequestedCategories(const std::string& c) {
  std::vector<std::string> categories;
  if (!c.empty()) {
    bool known = false;
    for (const auto& t : Templates()) known |= t.category == c;
    if (!known) throw Error("--category: unknown category '" + c + "'");
    if (DesiredPairsFor(c).empty())
      throw Error("--category: '" + c +
                  "' has no desired anchor pair to unfold by (long_sleeve_shirt, pants, shorts, towel have)");
    categories.push_back(c);
  }
  return categories;
}

// --weights (resolved as every command does); empty for --weights none. The weighted
// runs need weights: the release's own calibration unless given.
fs::path WeightsPath(const UnfoldArgs& a, const fs::path& dir) {
  const bool unweighted = a.weights == "none";
  if (unweighted && a.ablations)
    throw Error("--ablations: the ablations are measured against the weighted loop; --weights none leaves none");
  fs::path wpath = recognition::ResolveWeightsPath(Release::Open(dir), a.weights);
  if (wpath.empty() && !unweighted)
    throw Error(dir.string() + ": the release has no learned weights (run `drape calibrate " + dir.string() +
                "` first, or pass --weights none)");
  return wpath;
}

// Every test category with a desired pair unless one was asked for; each must have
// database garments, weights (unless unweighted only) and a test instance.
void CheckCategories(const ReleaseModel& model, const fs::path& dir, bool unweighted_only,
                     std::vector<std::string>& categories) {
  if (categories.empty()) {
    for (const std::string& c : model.TestCategories())
      if (!DesiredPairsFor(c).empty()) categories.push_back(c);
    if (categories.empty()) throw Error(dir.string() + ": no test garment of a category with a desired anchor pair");
  }
  for (const std::string& c : categories) {
    if (!model.database().HasCategory(c))
      throw Error(dir.string() + ": the release's database has no '" + c + "' garments");
    if (model.weights() && !unweighted_only && !model.weights()->per_category.count(c))
      throw Error(dir.string() + ": the weights have no '" + c + "' category (calibrate the release again)");
    model.TestInstance(c);  // throws if the test split has none
  }
}

// What a trial writes beside its trace.
struct TrialOutput {
  bool figures = true;  // pictures (unless --no-figures)
  bool meshes = false;  // --dump-meshes: each step's reconstruction, true cloth and registration (object frame)
};

// OUT/<variant>/<category>/trial_<k>/trace.json and, unless --no-figures, its pictures.
void WriteTrialTrace(const TrialResult& t, const Variant& v, const std::string& c, int k, const ReleaseModel& model,
                     const TrialOutput& what, const fs::path& out) {
  std::string vdir = v.name == "full" ? "" : v.name;
  for (char& ch : vdir)
    if (ch == ' ') ch = '_';
  const fs::path td = out / vdir / c / ("trial_" + std::to_string(k + 1));
  fs::create_directories(td);
  Json trace = t.ToJson();
  trace["variant"] = v.name;
  if (t.placed) {
    // The garment as it lies, for drape fold (runtime/folding/placed.h).
    const auto& tg = model.TestInstance(c);
    folding::WritePlacedGarment(td, {tg.garment, t.final_mesh.V, tg.material.name, tg.fit.stiffness, tg.fit.friction});
    trace["placed_garment"] = "placed.json";
  }
  if (what.figures) trace["figures"] = WriteTrialFigures(t, model.TestInstance(c).garment, t.sensing_height, td);
  if (what.meshes) {
    ExportGarment(model.TestInstance(c).garment, td / "garment.ply");  // its anchors' vertices index the cloth
    for (size_t i = 0; i < t.steps.size(); ++i) {
      const Step& s = t.steps[i];
      const std::string p = "step_" + std::to_string(i + 1) + "_";
      if (s.observe.recon.NumFaces() > 0) WriteMesh(s.observe.recon, td / (p + "recon.ply"));
      if (s.truth.cloth.NumFaces() > 0) WriteMesh(s.truth.cloth, td / (p + "cloth.ply"));
      if (s.plan.registered.NumFaces() > 0) WriteMesh(s.plan.registered, td / (p + "registered.ply"));
    }
  }
  WriteFileAtomic(td / "trace.json", trace.dump(2) + "\n");
}

// One variant's trials on one category (`only`: these 0-based trials of the `trials`) (seeds derived from the run's
// seed, the category and the trial), summarised as a table row. With jobs > 1 the trials run side by side (each its own
// world and seeds: the same results for any job count), and the progress lines interleave.
TableRow RunTrials(const ReleaseModel& model, const Variant& v, const std::string& c, const LoopOptions& lo, int trials,
                   const std::vector<int>& only, uint64_t seed, const std::optional<fs::path>& out,
                   const TrialOutput& what, int jobs) {
  const bool tty = isatty(fileno(stderr)) && jobs == 1;
  std::vector<int> ks = only;
  if (ks.empty())
    for (int k = 0; k < trials; ++k) ks.push_back(k);
  std::vector<TrialResult> results(ks.size());
  std::mutex say_mu;
  ParallelFor(static_cast<int>(ks.size()), jobs, [&](int i) {
    const int k = ks[i];
    LoopOptions o = lo;
    o.regrasp.ir_refinement = v.ir, o.plan.nonrigid = v.nonrigid, o.recognise.weighted = v.weighted;
    const uint64_t ts = DeriveSeed(seed, c + "/trial/" + std::to_string(k));
    auto say = [&](const std::string& s) {
      std::lock_guard<std::mutex> lock(say_mu);
      std::cerr << (tty ? "\r\033[K" : "") << "[" << v.name << " " << c << " " << k + 1 << "/" << trials << "] " << s
                << (tty ? "" : "\n") << std::flush;
    };
    TrialResult t = RunTrial(model, c, o, ts, say);
    char line[320], pair[48] = "";
    if (t.final_pair_distance >= 0)
      std::snprintf(pair, sizeof pair, ", grippers %.1f cm from a desired pair", 100 * t.final_pair_distance);
    std::snprintf(line, sizeof line, "%s, %d regrasps, f %.2f%s, %.0f s%s%s", t.unfolded ? "unfolded" : "not unfolded",
                  t.regrasps, t.final_f, pair, t.seconds, t.failure.empty() ? "" : ": ", t.failure.c_str());
    say(line);
    if (tty) std::cerr << "\n";
    if (out) WriteTrialTrace(t, v, c, k, model, what, *out);
    results[i] = std::move(t);
  });
  return Summarise(c, v.name, results);
}

// --only K,K,... (CLI11 has checked each is an integer >= 1): 0-based trial indices, each
// K at most --trials, in the order given, each once; empty: all.
std::vector<int> OnlyTrials(const std::vector<int>& given, int trials) {
  std::vector<int> ks;
  for (int k : given) {
    if (k > trials)
      throw Error("--only: '" + std::to_string(k) + "' is not a trial number in 1.." + std::to_string(trials));
    if (std::find(ks.begin(), ks.end(), k - 1) == ks.end()) ks.push_back(k - 1);
  }
  return ks;
}

// The loop's options as report.json records them.
Json OptionsJson(const LoopOptions& lo, int trials, const std::vector<int>& only, uint64_t seed) {
  Json only_j = Json::array();
  for (int k : only) only_j.push_back(k + 1);
  return {{"trials", trials},
          {"only", only_j},
          {"seed", seed},
          {"frames", lo.observe.capture.frames},
          {"max_regrasps", lo.max_regrasps},
          {"sigma_length_m", lo.plan.objective.sigma_length},
          {"xi", lo.plan.objective.xi},
          {"success_distance_m", lo.success_distance},
          {"log_sigma_samples", lo.regrasp.refine.sigma_samples},
          {"ir_sample_spacing_m", lo.regrasp.refine.sample_spacing},
          {"ir_search_half_width_m", lo.regrasp.refine.search_half_width_samples * lo.regrasp.refine.sample_spacing},
          {"plan_prior_top_k", lo.recognise.plan_prior_top_k},
          {"category_known", lo.recognise.category_known},
          {"refit_absent_penalty", lo.recognise.refit_absent_penalty},
          {"candidates", lo.plan.candidates},
          {"lowest_near_radius_m", lo.plan.lowest.near_radius},
          {"verify", lo.verify},
          {"place_flat", lo.place_flat}};
}

int RunUnfold(const UnfoldArgs& a) {
  const fs::path dir = a.release;
  const std::vector<int> only = OnlyTrials(a.only, a.trials);
  LoopOptions lo;
  kUnfoldSection.Read(OptionsFile::LoadIfGiven(a.config), lo);

  std::vector<std::string> categories = RequestedCategories(a.category);
  const bool unweighted = a.weights == "none";
  const fs::path wpath = WeightsPath(a, dir);
  const ReleaseModel model(dir, wpath);
  CheckCategories(model, dir, unweighted, categories);

  if (a.jobs > 1) lo.observe.fusion_threads = 1;  // the trials share the cores instead
  std::vector<Variant> variants;
  variants.push_back({"full", lo.regrasp.ir_refinement, lo.plan.nonrigid, !unweighted});
  if (a.ablations) {
    variants = {{"full"},
                {"no IR refinement", false, true, true},
                {"rigid-only registration", true, false, true},
                {"unweighted recognition", true, true, false}};
  }
  const std::optional<fs::path> out = a.output.empty() ? std::nullopt : std::optional<fs::path>(a.output);
  std::vector<TableRow> rows;
  for (const Variant& v : variants)
    for (const std::string& c : categories)
      rows.push_back(RunTrials(model, v, c, lo, a.trials, only, a.seed, out, {!a.no_figures, a.dump_meshes}, a.jobs));
  const std::string md = ReportMarkdown(rows);
  std::cout << md;
  if (out) {
    Json rj = ReportJson(rows);
    rj["release"] = dir.string();
    rj["digest"] = model.release().digest();
    rj["weights"] = wpath.empty() ? Json(nullptr) : Json(wpath.string());
    rj["options"] = OptionsJson(lo, a.trials, only, a.seed);
    rj["provenance"] = RunProvenance();
    WriteFileAtomic(*out / "report.json", rj.dump(2) + "\n");
    WriteFileAtomic(*out / "report.md", "# Unfolding\n\n" + md);
    std::cout << "report: " << (*out / "report.md").string() << "\n";
  }
  return 0;
}

Runner Setup(CLI::App& app) {
  auto a = std::make_shared<UnfoldArgs>();
  app.footer(kFooter);
  app.add_option("RELEASE", a->release, "the release (calibrated: drape calibrate RELEASE)")->required();
  app.add_option("--category", a->category, "only this category (default: every test category with a desired pair)")
      ->type_name("C");
  AddCount(app, "--trials", a->trials, "trials per category");
  app.add_option("--only", a->only,
                 "run only these of the N trials (1-based; each with the seed it has in the full run)")
      ->type_name("K,K,...")
      ->delimiter(',')
      ->allow_extra_args(false)  // one K,K,... per --only: RELEASE after it stays the release
      ->check(IntegerIn(1, std::numeric_limits<int>::max()));
  AddSeed(app, a->seed, "trial seeds derive from S, the category and the trial");
  AddOutput(app, a->output,
            "write <category>/trial_<k>/{trace.json, *.png} and report.md/.json into this folder; a garment "
            "placed flat also as placed.json, garment.ply, lying.ply in its trial folder");
  AddWeights(app, a->weights);
  AddJobs(app, a->jobs, "trials run side by side (default 1; the same results for any N)");
  app.add_flag("--ablations", a->ablations,
               "also run the three ablations: no IR refinement, rigid-only registration, unweighted (4x the trials)");
  app.add_flag("--no-figures", a->no_figures, "traces only");
  app.add_flag("--dump-meshes", a->dump_meshes,
               "per step also step_K_recon.ply, step_K_cloth.ply (truth), step_K_registered.ply and the test "
               "garment (garment.ply + garment.anchors.json)");
  AddConfig(app, a->config);
  return [a] { return RunUnfold(*a); };
}

Register reg({"unfold", "regrasp and unfold test garments with simulated dual-arm hardware", Setup});

}  // namespace
}  // namespace drape::cli
