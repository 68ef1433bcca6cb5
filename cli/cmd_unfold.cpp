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
    "  --category-known  tell recognition the category\n"
    "  --category-once   decide the category at the first step and keep it for the trial\n"
    "                    (default: by registration at every hang, the fits summed over the hangs\n"
    "                    deciding, docs/unfolding.md \"The category at every hang\")\n"
    "  --refit-absent P  at every hang, a category left out of the hang's registration counts\n"
    "                    the hang's worst score + P (default 0.5)\n"
    "  --category-evidence  decide it from every hang: each adds each category's Eq. match\n"
    "                    distance over the nearest's, within the height gate and without it;\n"
    "                    the pose is recognised within the category with the least sum, and\n"
    "                    a change re-plans with its desired pairs (off: it takes shorts for\n"
    "                    pants, docs/unfolding.md)\n"
    "  --no-category-fit the category by recognition's nearest neighbour (default:\n"
    "                    by registration, docs/recognition.md \"The category by registration\";\n"
    "                    off with --category-known or --category-evidence)\n"
    "  --first-hang-weight W  weight of the random first grasp's hang in that evidence (default 1;\n"
    "                    a hang after an aimed regrasp weighs 1)\n"
    "  --gated-out-excess E  the least excess (fraction of the feature's bits) of a category that\n"
    "                    the height gate leaves out at a hang (default 0.01)\n"
    "  --category-gate T the height gate of that evidence, |ln(h / h_entry)| <= T (default -1:\n"
    "                    the weights' category gate, recognition's; 0 = none)\n"
    "  --category-ungated W  that evidence adds W x each category's excess without the gate\n"
    "                    (default 1; 0 = within the gate only)\n"
    "  --plan-prior K    after a regrasp keep the anchor it aimed at (or its twin) when recognition\n"
    "                    ranks it among its top K (default 3; 0 = recognise afresh, as the paper)\n"
    "  --no-trust-aimed  keep the aimed anchor only within recognition's top K (default: after a\n"
    "                    regrasp that pinched cloth the anchor it aimed at, or its twin, is kept\n"
    "                    whatever recognition ranks)\n"
    "  --first-holder-stops  the paper's rule: stop at f >= xi on any holder (default: not on\n"
    "                    the random first grasp; at f >= xi there the regrasp goes ahead and\n"
    "                    the first gripper lets go)\n"
    "  --candidates K    register recognition's top K database entries (its answer first; after a\n"
    "                    kept plan prior only that anchor's or its twin's) and predict from the\n"
    "                    best fit: symmetric mean surface distance to the reconstruction\n"
    "                    (default 5; 1 = recognition's answer alone)\n"
    "  --candidate-fit F the fit after the 'rigid' registration or after the 'final' one used\n"
    "                    (R + N unless --rigid; default rigid)\n"
    "  --candidate-fit-radius R  the fit over the cloth within R metres of each candidate's\n"
    "                    registered target anchor only (default 0: the whole garment)\n"
    "  --candidate-point P  where the regrasp goes: 'fit' (default: the kept candidate's own\n"
    "                    point) or 'consensus' (the kept candidate's plan, the point of the\n"
    "                    candidate aiming at its target or the twin with the most others\n"
    "                    within 3 cm, ties by fit) or 'outlier' (the kept candidate's point\n"
    "                    unless the medoid of at least two others aiming at its target or the\n"
    "                    twin lies more than 4 cm from it, then the medoid's)\n"
    "  --unobserved-margin M  an anchor registered more than M metres outside the fusion's\n"
    "                    segmentation region is predicted at its rigid registration, not mapped\n"
    "                    onto the reconstruction (e.g. 0.02; default -1: always mapped, the paper's rule)\n"
    "  --no-lowest-point regrasp at the registered anchor always, as the paper (default: when\n"
    "                    the database hang has the target as its lowest point, at the\n"
    "                    reconstruction's lowest point, 2 cm above it)\n"
    "  --lowest-near R   when the target is not the database hang's lowest point but the\n"
    "                    lowest within R metres of it, regrasp at the reconstruction's lowest\n"
    "                    point within R of the registered target, 2 cm above it (default 0.06; 0: off)\n"
    "  --no-hanging-end  regrasp an elbow at its registered point, as the paper (default: at the\n"
    "                    reconstruction's lowest point near the registered cuff, raised by the\n"
    "                    pattern's elbow-to-cuff distance, when the database hang has the cuff below)\n"
    "  --no-ir           ablation: grasp the registered point without IR refinement\n"
    "  --ir-above-jaws   the IR scan as first built: the jaw centre crosses the prediction and\n"
    "                    the beam (3 cm above the jaws) reads the cloth above it (default: the\n"
    "                    beam crosses the prediction, at the jaws' height)\n"
    "  --hem-edge        when the registered database hang has the target at the lower edge of\n"
    "                    its cloth (a hem corner: leg ends), also scan vertically through the\n"
    "                    refined point and close 1 cm above the lowest reading of the surface\n"
    "                    found at or below it (off by default; not with --ir-above-jaws or --no-ir)\n"
    "  --hem-corner      with --hem-edge, once the hem is found: scan along it at the jaws' height\n"
    "                    and close 2 cm in from its end on the side the registered hang has\n"
    "                    its cloth away from (off by default)\n"
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
      if (s.recon.NumFaces() > 0) WriteMesh(s.recon, td / (p + "recon.ply"));
      if (s.cloth.NumFaces() > 0) WriteMesh(s.cloth, td / (p + "cloth.ply"));
      if (s.registered.NumFaces() > 0) WriteMesh(s.registered, td / (p + "registered.ply"));
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
    o.ir_refinement = v.ir, o.nonrigid = v.nonrigid, o.weighted = v.weighted;
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

// --candidates, --candidate-fit, --candidate-point into `lo`.
void CandidateOptions(const Args& a, LoopOptions& lo) {
  lo.candidates = static_cast<int>(a.GetInt("--candidates").value_or(lo.candidates));
  if (lo.candidates < 1 || lo.candidates > 10) throw Error("--candidates: must be in 1..10");
  if (const auto fit = a.Get("--candidate-fit")) {
    if (*fit != "rigid" && *fit != "final")
      throw Error("--candidate-fit: must be 'rigid' or 'final' (got '" + *fit + "')");
    lo.fit_after_rigid = *fit == "rigid";
  }
  if (const auto r = a.GetDouble("--candidate-fit-radius")) {
    if (!(*r >= 0 && *r <= 1)) throw Error("--candidate-fit-radius: must be in [0, 1] m");
    lo.fit_radius = *r;
  }
  if (const auto point = a.Get("--candidate-point")) {
    if (*point != "consensus" && *point != "fit" && *point != "outlier")
      throw Error("--candidate-point: must be 'consensus', 'outlier' or 'fit' (got '" + *point + "')");
    lo.consensus_radius = *point == "consensus" ? kConsensusRadius : 0;
    lo.outlier_radius = *point == "outlier" ? kOutlierRadius : 0;
  }
}

// --plan-prior, --no-trust-aimed, --first-holder-stops.
void PlanPriorOptions(const Args& a, LoopOptions& lo) {
  lo.plan_prior_top_k = static_cast<int>(a.GetInt("--plan-prior").value_or(lo.plan_prior_top_k));
  if (lo.plan_prior_top_k < 0 || lo.plan_prior_top_k > 5) throw Error("--plan-prior: must be in 0..5");
  if (a.Flag("--no-trust-aimed")) lo.trust_aimed = false;
  lo.verify_first_holder = !a.Flag("--first-holder-stops");
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

// The category from every hang (--category-evidence and its parameters).
void CategoryOptions(const Args& a, LoopOptions& lo) {
  if (a.Flag("--category-once") && a.Flag("--category-evidence"))
    throw Error("--category-once and --category-evidence: give one");
  lo.category_evidence = a.Flag("--category-evidence");
  lo.category_fit = !a.Flag("--no-category-fit") && !lo.category_evidence && !a.Flag("--category-known");
  lo.category_refit = lo.category_fit && !a.Flag("--category-once");
  lo.refit_absent_penalty = a.GetDouble("--refit-absent").value_or(lo.refit_absent_penalty);
  if (!(lo.refit_absent_penalty >= 0)) throw Error("--refit-absent: must be >= 0");
  lo.first_hang_weight = a.GetDouble("--first-hang-weight").value_or(lo.first_hang_weight);
  if (!(lo.first_hang_weight >= 0)) throw Error("--first-hang-weight: must be >= 0");
  lo.gated_out_excess = a.GetDouble("--gated-out-excess").value_or(lo.gated_out_excess);
  if (!(lo.gated_out_excess >= 0)) throw Error("--gated-out-excess: must be >= 0");
  lo.category_gate = a.GetDouble("--category-gate").value_or(lo.category_gate);
  if (!(lo.category_gate < 3)) throw Error("--category-gate: must be below 3");
  lo.category_ungated_weight = a.GetDouble("--category-ungated").value_or(lo.category_ungated_weight);
  if (!(lo.category_ungated_weight >= 0)) throw Error("--category-ungated: must be >= 0");
}

// The loop's options as report.json records them.
Json OptionsJson(const LoopOptions& lo, int trials, const std::vector<int>& only, uint64_t seed) {
  Json only_j = Json::array();
  for (int k : only) only_j.push_back(k + 1);
  return {{"trials", trials},
          {"only", only_j},
          {"seed", seed},
          {"frames", lo.capture.frames},
          {"max_regrasps", lo.max_regrasps},
          {"sigma_length_m", lo.objective.sigma_length},
          {"xi", lo.objective.xi},
          {"success_distance_m", lo.success_distance},
          {"log_sigma_samples", lo.refine.sigma_samples},
          {"ir_sample_spacing_m", lo.refine.sample_spacing},
          {"ir_search_half_width_m", lo.refine.search_half_width_samples * lo.refine.sample_spacing},
          {"plan_prior_top_k", lo.plan_prior_top_k},
          {"trust_aimed", lo.trust_aimed},
          {"verify_first_holder", lo.verify_first_holder},
          {"category_evidence", lo.category_evidence},
          {"category_fit", lo.category_fit},
          {"category_refit", lo.category_refit},
          {"refit_absent_penalty", lo.refit_absent_penalty},
          {"first_hang_weight", lo.first_hang_weight},
          {"gated_out_excess", lo.gated_out_excess},
          {"category_gate", lo.category_gate},
          {"category_ungated_weight", lo.category_ungated_weight},
          {"candidates", lo.candidates},
          {"candidate_fit", lo.fit_after_rigid ? "rigid" : "final"},
          {"candidate_point", lo.consensus_radius > 0 ? "consensus"
                              : lo.outlier_radius > 0 ? "outlier"
                                                      : "fit"},
          {"outlier_radius_m", lo.outlier_radius},
          {"consensus_radius_m", lo.consensus_radius},
          {"ir_at_jaw_line", lo.ir_at_jaw_line},
          {"hem_edge", lo.hem_edge},
          {"hem_corner", lo.hem_corner},
          {"candidate_fit_radius_m", lo.fit_radius},
          {"lowest_point", lo.lowest_point},
          {"lowest_near_radius_m", lo.lowest.near_radius},
          {"hanging_end", lo.hanging_end},
          {"place_flat", lo.place_flat}};
}

// drape unfold's flags and its options with a value.
const std::vector<std::string> kUnfoldFlags = {"--no-ir",          "--ir-above-jaws",      "--rigid",
                                               "--unweighted",     "--ablations",          "--no-figures",
                                               "--no-place",       "--dump-meshes",        "--category-known",
                                               "--category-once",  "--category-evidence",  "--no-category-fit",
                                               "--no-trust-aimed", "--first-holder-stops", "--hem-edge",
                                               "--hem-corner",     "--no-lowest-point",    "--no-hanging-end"};
const std::vector<std::string> kUnfoldValues = {"--category",
                                                "--trials",
                                                "--only",
                                                "--seed",
                                                "-o",
                                                "--weights",
                                                "--frames",
                                                "--max-regrasps",
                                                "--jobs",
                                                "--plan-prior",
                                                "--candidates",
                                                "--candidate-fit",
                                                "--candidate-fit-radius",
                                                "--candidate-point",
                                                "--unobserved-margin",
                                                "--first-hang-weight",
                                                "--refit-absent",
                                                "--gated-out-excess",
                                                "--category-gate",
                                                "--category-ungated",
                                                "--lowest-near"};

// The loop's options from the command line.
LoopOptions LoopOptionsFrom(const Args& a) {
  LoopOptions lo;
  lo.capture.frames = static_cast<int>(a.GetInt("--frames").value_or(550));
  lo.max_regrasps = static_cast<int>(a.GetInt("--max-regrasps").value_or(4));
  lo.category_known = a.Flag("--category-known");
  CategoryOptions(a, lo);
  lo.ir_at_jaw_line = !a.Flag("--ir-above-jaws");
  lo.hem_edge = a.Flag("--hem-edge");
  lo.lowest_point = !a.Flag("--no-lowest-point");
  lo.lowest.near_radius = a.GetDouble("--lowest-near").value_or(lo.lowest.near_radius);
  if (!(lo.lowest.near_radius >= 0 && lo.lowest.near_radius < 0.5)) throw Error("--lowest-near: must be in [0, 0.5) m");
  lo.hanging_end = !a.Flag("--no-hanging-end");
  lo.hem_corner = a.Flag("--hem-corner");
  if (lo.hem_corner && !lo.hem_edge) throw Error("--hem-corner: needs --hem-edge");
  lo.place_flat = !a.Flag("--no-place");
  PlanPriorOptions(a, lo);
  CandidateOptions(a, lo);
  lo.unobserved_margin = a.GetDouble("--unobserved-margin").value_or(lo.unobserved_margin);
  if (!(lo.unobserved_margin < 0.5)) throw Error("--unobserved-margin: must be below 0.5 m");
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
  if (jobs > 1) lo.fusion_threads = 1;  // the trials share the cores instead
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
