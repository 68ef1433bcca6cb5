// drape unfold: the regrasping/unfolding loop (paper §"Online Model Registration for
// Regrasping and Unfolding") on simulated dual-arm hardware, trials and the paper's table.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <sstream>

#include "cli/args.h"
#include "cli/command.h"
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

const char* kUsage =
    "Usage: drape unfold RELEASE [--category C] [--trials N] [--seed S] [-o DIR] [options]\n"
    "\n"
    "Unfolds test garments of the release with simulated dual-arm hardware (paper Algorithm\n"
    "\"Iterative Procedure for Regrasping\"): pick up at a random point, turn in front of the\n"
    "Kinect, fuse, recognise the grasped anchor (learned weights), register the matched\n"
    "database mesh, choose the next grasp by the objective f over anchor pairs (Eq. finalobj),\n"
    "refine it with the IR range sensor (LoG), regrasp with the free arm; until f >= xi.\n"
    "Desired pairs: long_sleeve_shirt both elbows, pants/shorts the outer leg-opening corners,\n"
    "towel two adjacent corners.\n"
    "\n"
    "Options:\n"
    "  --category C      only this category (default: every test category with a desired pair)\n"
    "  --trials N        trials per category (default 10)\n"
    "  --only K,K,...    run only these of the N trials (1-based; each with the seed it has in\n"
    "                    the full run), e.g. to rerun the trials an option changes\n"
    "  --seed S          trial seeds derive from S (default 1)\n"
    "  -o DIR            write DIR/<category>/trial_<k>/{trace.json, *.png}, DIR/report.md/.json;\n"
    "                    a garment placed flat also as placed.json, garment.ply, lying.ply there\n"
    "                    (drape fold DIR/<category>/trial_<k> --plan PLAN folds it as it lies)\n"
    "  --weights PATH    weights.json (default RELEASE/calibration/weights.json; required unless\n"
    "                    --unweighted)\n"
    "  --frames N        Kinect frames per turn, 360 deg one way and back (default 550, the paper's)\n"
    "  --max-regrasps K  give up after K regrasps (default 4)\n"
    "  --jobs N          trials run side by side on N threads (default 1; same results for any N)\n"
    "  --category-known  tell recognition the category (default: by registration at every hang,\n"
    "                    the fits summed over the hangs deciding)\n"
    "  --refit-absent P  at every hang, a category left out of the hang's registration counts\n"
    "                    the hang's worst score + P (default 0.5)\n"
    "  --plan-prior K    after a regrasp keep the anchor it aimed at (or its twin) as recognition's\n"
    "                    top-K anchor when it ranks it there, else as that anchor's best entry\n"
    "                    (default 3)\n"
    "  --candidates K    register recognition's top K database entries (its answer first; after a\n"
    "                    kept plan prior only that anchor's or its twin's) and predict from the\n"
    "                    best fit after rigid registration: symmetric mean surface distance to\n"
    "                    the reconstruction (default 5; 1 = recognition's answer alone)\n"
    "  --lowest-near R   when the target is not the database hang's lowest point but the\n"
    "                    lowest within R metres of it, regrasp at the reconstruction's lowest\n"
    "                    point within R of the registered target, 2 cm above it (default 0.06; 0: off)\n"
    "  --no-ir           ablation: grasp the registered point without IR refinement\n"
    "  --rigid           ablation: rigid-only registration\n"
    "  --unweighted      ablation: unweighted recognition (Eq. match)\n"
    "  --ablations       also run the three ablations (4x the trials)\n"
    "  --no-figures      traces only\n"
    "  --dump-meshes     per step also step_K_recon.ply (the reconstruction), step_K_cloth.ply (truth: the\n"
    "                    cloth as it hung, same frame), step_K_registered.ply (the kept registration)\n"
    "                    and the test garment (garment.ply + garment.anchors.json)\n"
    "  --no-place        do not lay the garment flat once f >= xi (no coverage; success is judged\n"
    "                    before placing, so it is the same; the placing is a long cloth simulation)\n";

struct Variant {
  std::string name;
  bool ir = true, nonrigid = true, weighted = true;
};

// --category, checked before anything expensive: a known category with a desired pair.
std::vector<std::string> RequestedCategories(const Args& a) {
  std::vector<std::string> categories;
  if (auto c = a.Get("--category")) {
    bool known = false;
    for (const auto& t : Templates()) known |= t.category == *c;
    if (!known) throw Error("--category: unknown category '" + *c + "'");
    if (DesiredPairsFor(*c).empty())
      throw Error("--category: '" + *c +
                  "' has no desired anchor pair to unfold by (long_sleeve_shirt, pants, shorts, towel have)");
    categories.push_back(*c);
  }
  return categories;
}

// --weights, else the release's calibration; empty when only unweighted runs need none.
fs::path WeightsPath(const Args& a, const fs::path& dir, bool unweighted_only) {
  fs::path wpath = a.Get("--weights", "");
  if (wpath.empty()) {
    const Release probe = Release::Open(dir);
    wpath = recognition::DefaultWeightsDir(probe) / "weights.json";
    if (!fs::exists(wpath)) {
      if (!unweighted_only)
        throw Error(dir.string() + ": the release has no learned weights (run `drape calibrate " + dir.string() +
                    "` first, or pass --unweighted)");
      wpath.clear();
    }
  }
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
                     const LoopOptions& o, const TrialOutput& what, const fs::path& out) {
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
    if (out) WriteTrialTrace(t, v, c, k, model, o, what, *out);
    results[i] = std::move(t);
  });
  return Summarise(c, v.name, results);
}

// --plan-prior, --candidates.
void PlanOptions(const Args& a, LoopOptions& lo) {
  lo.recognise.plan_prior_top_k = static_cast<int>(a.GetInt("--plan-prior").value_or(lo.recognise.plan_prior_top_k));
  if (lo.recognise.plan_prior_top_k < 0 || lo.recognise.plan_prior_top_k > 5)
    throw Error("--plan-prior: must be in 0..5");
  lo.plan.candidates = static_cast<int>(a.GetInt("--candidates").value_or(lo.plan.candidates));
  if (lo.plan.candidates < 1 || lo.plan.candidates > 10) throw Error("--candidates: must be in 1..10");
}

// --only K,K,...: 0-based trial indices, each in 1..trials as given; empty: all.
std::vector<int> OnlyTrials(const Args& a, int trials) {
  std::vector<int> ks;
  const auto list = a.Get("--only");
  if (!list) return ks;
  std::string item;
  std::istringstream is(*list);
  while (std::getline(is, item, ',')) {
    size_t used = 0;
    int k = 0;
    try {
      k = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || k < 1 || k > trials)
      throw Error("--only: '" + item + "' is not a trial number in 1.." + std::to_string(trials));
    if (std::find(ks.begin(), ks.end(), k - 1) == ks.end()) ks.push_back(k - 1);
  }
  if (ks.empty()) throw Error("--only: no trial given");
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
          {"place_flat", lo.place_flat}};
}

// drape unfold's flags and its options with a value.
const std::vector<std::string> kUnfoldFlags = {"--no-ir",      "--rigid",    "--unweighted",  "--ablations",
                                               "--no-figures", "--no-place", "--dump-meshes", "--category-known"};
const std::vector<std::string> kUnfoldValues = {"--category",   "--trials",     "--only",       "--seed",
                                                "-o",           "--weights",    "--frames",     "--max-regrasps",
                                                "--jobs",       "--plan-prior", "--candidates", "--refit-absent",
                                                "--lowest-near"};

// The loop's options from the command line.
LoopOptions LoopOptionsFrom(const Args& a) {
  LoopOptions lo;
  lo.observe.capture.frames = static_cast<int>(a.GetInt("--frames").value_or(550));
  lo.max_regrasps = static_cast<int>(a.GetInt("--max-regrasps").value_or(4));
  lo.recognise.category_known = a.Flag("--category-known");
  lo.recognise.refit_absent_penalty = a.GetDouble("--refit-absent").value_or(lo.recognise.refit_absent_penalty);
  if (!(lo.recognise.refit_absent_penalty >= 0)) throw Error("--refit-absent: must be >= 0");
  lo.plan.lowest.near_radius = a.GetDouble("--lowest-near").value_or(lo.plan.lowest.near_radius);
  if (!(lo.plan.lowest.near_radius >= 0 && lo.plan.lowest.near_radius < 0.5))
    throw Error("--lowest-near: must be in [0, 0.5) m");
  lo.place_flat = !a.Flag("--no-place");
  PlanOptions(a, lo);
  return lo;
}

int RunUnfold(const std::vector<std::string>& argv) {
  Args a(argv, kUnfoldFlags, kUnfoldValues);
  if (a.help()) {
    std::cout << kUsage;
    return 0;
  }
  a.RequirePositional(1, 1, "RELEASE");
  const fs::path dir = a.positional()[0];
  const int trials = static_cast<int>(a.GetInt("--trials").value_or(10));
  if (trials < 1) throw Error("--trials: must be >= 1");
  const uint64_t seed = static_cast<uint64_t>(a.GetInt("--seed").value_or(1));
  const std::vector<int> only = OnlyTrials(a, trials);

  std::vector<std::string> categories = RequestedCategories(a);
  const bool unweighted_only = a.Flag("--unweighted") && !a.Flag("--ablations");
  const fs::path wpath = WeightsPath(a, dir, unweighted_only);
  const ReleaseModel model(dir, wpath);
  CheckCategories(model, dir, unweighted_only, categories);

  LoopOptions lo = LoopOptionsFrom(a);
  const int jobs = static_cast<int>(a.GetInt("--jobs").value_or(1));
  if (jobs < 1) throw Error("--jobs: must be >= 1");
  if (jobs > 1) lo.observe.fusion_threads = 1;  // the trials share the cores instead
  std::vector<Variant> variants;
  variants.push_back({"full", !a.Flag("--no-ir"), !a.Flag("--rigid"), !a.Flag("--unweighted")});
  if (a.Flag("--ablations")) {
    variants = {{"full"},
                {"no IR refinement", false, true, true},
                {"rigid-only registration", true, false, true},
                {"unweighted recognition", true, true, false}};
  }
  const std::optional<fs::path> out = a.Get("-o") ? std::optional<fs::path>(*a.Get("-o")) : std::nullopt;
  std::vector<TableRow> rows;
  for (const Variant& v : variants)
    for (const std::string& c : categories)
      rows.push_back(RunTrials(model, v, c, lo, trials, only, seed, out,
                               {!a.Flag("--no-figures"), a.Flag("--dump-meshes")}, jobs));
  const std::string md = ReportMarkdown(rows);
  std::cout << md;
  if (out) {
    Json rj = ReportJson(rows);
    rj["release"] = dir.string();
    rj["digest"] = model.release().digest();
    rj["weights"] = wpath.empty() ? Json(nullptr) : Json(wpath.string());
    rj["options"] = OptionsJson(lo, trials, only, seed);
    rj["provenance"] = RunProvenance();
    WriteFileAtomic(*out / "report.json", rj.dump(2) + "\n");
    WriteFileAtomic(*out / "report.md", "# Unfolding\n\n" + md);
    std::cout << "report: " << (*out / "report.md").string() << "\n";
  }
  return 0;
}

Register reg({"unfold", "regrasp and unfold test garments with simulated dual-arm hardware", kUsage, RunUnfold});

}  // namespace
}  // namespace drape::cli
