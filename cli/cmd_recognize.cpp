// drape recognize / calibrate / eval: pose recognition against a release (paper
// §"Pose Estimation"), RankSVM calibration of the weighted Hamming distance, and the
// evaluation report.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>

#include "cli/command.h"
#include "cli/config.h"
#include "cli/options.h"
#include "cli/sections.h"
#include "common/error.h"
#include "common/format.h"
#include "common/timing.h"
#include "common/version.h"
#include "generator/release/release.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/category_fit.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/k_curve.h"
#include "runtime/recognition/ladder.h"
#include "runtime/recognition/miss_curve.h"
#include "runtime/recognition/registration_eval.h"
#include "runtime/recognition/release_query.h"
#include "runtime/recognition/release_recipe.h"
#include "runtime/recognition/release_source.h"

namespace drape::cli {
namespace {

namespace fs = std::filesystem;
using namespace drape::recognition;

// "a,b,c" → {"a", "b", "c"}; a name may not be empty.
std::vector<std::string> SplitList(const std::string& list) {
  std::vector<std::string> out;
  size_t start = 0;
  while (true) {
    const size_t comma = list.find(',', start);
    out.push_back(list.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (out.back().empty()) throw Error("--split '" + list + "': empty split name");
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

std::string Fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// ------------------------------------------------------------------ the options file

// `matching`: the XOR-popcount kernel (recognize, eval; the results are the same).
struct MatchingKnobs {
  std::string kernel = "auto";
  Kernel Parsed() const {
    if (kernel == "auto") return Kernel::kAuto;
    if (kernel == "generic") return Kernel::kGeneric;
    if (kernel == "popcnt") return Kernel::kPopcnt;
    if (kernel == "avx512") return Kernel::kAvx512;
    BadField(kernel, "kernel", "'" + kernel + "' is not one of auto, generic, popcnt, avx512");
  }
  void Validate() const { Parsed(); }
};
const ConfigSection<MatchingKnobs> kMatchingSection(
    "matching", "Eq. match over the database (`drape recognize`, `drape eval`); every kernel gives the same bits.",
    {{"kernel", Ref(&MatchingKnobs::kernel), "name",
      "`auto` (the best this CPU has), `generic`, `popcnt` or `avx512`"}});

// `recognize`: a query's search restricted to one database garment instance.
struct RecognizeKnobs {
  std::string instance;
  void Validate() const {}
};
const ConfigSection<RecognizeKnobs> kRecognizeSection(
    "recognize", "`drape recognize`'s search.",
    {{"instance", Ref(&RecognizeKnobs::instance), "name",
      "search only this database garment instance (\"\": every one)"}});

// `category_fit`: the category by registration (recognize --entry, eval).
const ConfigSection<CategoryFitOptions> kCategoryFitSection(
    "category_fit",
    "The category by registration (`drape recognize --entry`, `drape eval`; runtime/recognition/category_fit.h): "
    "the nearest categories' best entries registered onto the query's reconstruction, the best fit deciding.",
    {{"per_category", Ref(&CategoryFitOptions::per_category), "entries", "entries registered per category"},
     {"top_categories", Ref(&CategoryFitOptions::top_categories), "categories",
      "only the N categories nearest by Eq. match (0: every one in the height gate)"},
     {"bits_weight", Ref(&CategoryFitOptions::bits_weight), "—",
      "λ, the weight of the Hamming distance in the score (0: the fit alone)"},
     {"scale", Ref(&CategoryFitOptions::scale), "bool", "registration's scale step"}});

// `eval`: the registration table's size and the category fit's selection.
struct EvalKnobs {
  int registration_pairs = 0;
  bool category_fit_selection = false;
  void Validate() const {
    if (registration_pairs < 0) BadField(registration_pairs, "registration_pairs", "must be >= 0 (0 = all)");
  }
};
const ConfigSection<EvalKnobs> kEvalSection(
    "eval", "`drape eval`'s extra work.",
    {{"registration_pairs", Ref(&EvalKnobs::registration_pairs), "pairs",
      "at most this many registration pairs per category (0: every test entry)"},
     {"category_fit_selection", Ref(&EvalKnobs::category_fit_selection), "bool",
      "also choose the category_fit settings on train + calibration (report.json \"category_fit_selection\"; never "
      "reads the test split)"}});

// `calibrate`: the RankSVM's setting when it is fixed rather than cross-validated.
struct CalibrateKnobs {
  double c = -1;           // < 0: cross-validated
  std::string regularize;  // "" = uniform (with c)
  std::string tie;         // "" = annulus (with c)
  std::string frame = "database";
  double epsilon = 0.001;
  void Validate() const {
    if (!(c == -1 || c >= 0)) BadField(c, "c", "must be >= 0, or -1 for cross-validation");
    if (!(epsilon > 0)) BadField(epsilon, "epsilon", "must be > 0");
    Check(regularize, "regularize", [&] { ParseRegularizer(regularize); });
    Check(tie, "tie", [&] { ParseWeightTying(tie); });
    Check(frame, "frame", [&] { ParseWeightFrame(frame); });
    if (c < 0 && !(regularize.empty() && tie.empty()))
      BadField(c, "c", "regularize and tie go with a fixed c (without it both are cross-validated)");
  }
  template <typename F>
  static void Check(const std::string& field, const char* name, F parse) {
    if (field.empty()) return;
    try {
      parse();
    } catch (const Error& e) {
      BadField(field, name, e.what());
    }
  }
};
const ConfigSection<CalibrateKnobs> kCalibrateSection(
    "calibrate",
    "`drape calibrate`'s RankSVM when not cross-validated (docs/recognition.md, \"Learned weights that carry "
    "over\").",
    {{"c", Ref(&CalibrateKnobs::c), "—",
      "a fixed RankSVM penalty C instead of cross-validation (dlib scales it by 1/#pairs; with the uniform prior "
      "C = 0 gives w = 1); -1: cross-validated"},
     {"regularize", Ref(&CalibrateKnobs::regularize), "name",
      "with c: `uniform` (½‖w − 1‖², the default) or `zero` (½‖w‖², w ≥ 0, the paper's)"},
     {"tie", Ref(&CalibrateKnobs::tie), "name",
      "with c: `annulus` (one weight per layer × ring, the default), `bit` or `layer`"},
     {"frame", Ref(&CalibrateKnobs::frame), "name", "which frame w indexes: `database` or `query`"},
     {"epsilon", Ref(&CalibrateKnobs::epsilon), "—", "the solver's tolerance"}});

// --weights PATH | none (default: the release's calibration if present): the weights
// loaded into `w` (or none) and their path (empty = unweighted).
fs::path LoadWeightsFor(const Release& rel, const std::string& spec, std::optional<Weights>& w) {
  fs::path p = ResolveWeightsPath(rel, spec);
  if (!p.empty()) w = LoadWeights(p, rel.digest());
  return p;
}

// ------------------------------------------------------------------ recognize

const char* kRecognizeFooter =
    "Recognises the category and the grasped anchor of a garment held by a gripper, by nearest\n"
    "neighbour in the release's train split (the database): the category by registering the\n"
    "nearest categories' best entries onto an --entry query's reconstruction (else by the\n"
    "unweighted rotation-invariant Hamming distance, paper Eq. match), the anchor inside that\n"
    "category by the learned weighted distance (Eq. bestmatch) when the release has weights from\n"
    "`drape calibrate`. An --entry query uses its stored feature (fusion/feature times from the\n"
    "build's record); --sweep and --mesh queries are fused and featurised with the release's\n"
    "recipe options (a mesh in the object frame, gripper at the origin, y up, is swept first).";

struct RecognizeArgs {
  std::string release, entry, sweep, mesh, weights, category, config;
  int top_k = 5;
  uint64_t seed = 0;
  bool json = false, refuse = false, no_category_fit = false;
  const CLI::Option* seed_option = nullptr;
};

// The human-readable answer: query, truth, category, anchor and where it is, top k, times.
void PrintRecognition(const Json& query, const Json& timing, const Recognition& r, const Database& db,
                      const std::optional<Vec3>& hung, bool have_w) {
  const EntryLabel& bl = db.label(r.best.entry);
  std::cout << "query     " << query["kind"].get<std::string>() << " "
            << (query.contains("id") ? query["id"].get<std::string>() : query.value("path", "")) << "\n";
  if (query.contains("true_category")) {
    std::cout << "truth     " << query["true_category"].get<std::string>() << " / "
              << query["true_anchor"].get<std::string>() << " (" << query["split"].get<std::string>() << ")\n";
  }
  std::cout << "category  " << r.category << " ("
            << (r.category_source == "given"          ? "given"
                : r.category_source == "registration" ? "by registration"
                                                      : "unweighted nearest neighbour")
            << ")\n"
            << "anchor    " << r.anchor << "  — entry " << r.best.id << " (" << r.best.instance << "), distance "
            << r.best.distance << " bits, rotation " << r.best.rotation << " ("
            << Fmt("%.1f", 360.0 * r.best.rotation / db.sectors()) << "°)"
            << (r.weighted ? ", weighted " + Fmt("%.4g", r.best.score) : std::string(", unweighted")) << "\n";
  if (hung) {
    std::cout << "position  on the matched hung mesh (object frame): (" << Fmt("%.3f", (*hung)[0]) << ", "
              << Fmt("%.3f", (*hung)[1]) << ", " << Fmt("%.3f", (*hung)[2]) << ") m, vertex " << bl.anchor_vertex
              << "\n";
  }
  if (bl.anchor_uv) {
    std::cout << "          on its flat pattern: uv (" << Fmt("%.3f", (*bl.anchor_uv)[0]) << ", "
              << Fmt("%.3f", (*bl.anchor_uv)[1]) << ") m\n";
  }
  std::cout << "top " << r.top.size() << ":\n";
  for (size_t i = 0; i < r.top.size(); ++i) {
    std::cout << "  " << i + 1 << ". " << r.top[i].anchor << "  (" << r.top[i].id << ", distance " << r.top[i].distance
              << (r.weighted ? ", weighted " + Fmt("%.4g", r.top[i].score) : std::string()) << ")\n";
  }
  std::cout << "time      load database " << Fmt("%.3f", timing["load_database_seconds"].get<double>()) << " s ("
            << db.size() << " entries, once)";
  auto show = [&](const char* name, const char* key) {
    if (timing.contains(key) && !timing[key].is_null())
      std::cout << ", " << name << " " << Fmt("%.3f", timing[key].get<double>()) << " s";
    else if (timing.contains(key))
      std::cout << ", " << name << " n/a";
  };
  show("sweep", "sweep_seconds");
  show("fusion", "fusion_seconds");
  show("feature", "feature_seconds");
  std::cout << ", matching " << Fmt("%.6f", r.match_seconds) << " s\n";
  if (timing.contains("fusion_feature_source")) {
    std::cout << "          (fusion/feature: " << timing["fusion_feature_source"].get<std::string>() << ")\n";
  }
  if (timing.contains("refused")) {
    std::cout << "re-fused  fusion " << Fmt("%.3f", timing["refused"]["fusion_seconds"].get<double>()) << " s, feature "
              << Fmt("%.3f", timing["refused"]["feature_seconds"].get<double>())
              << " s; re-extracted vs stored feature: " << query["refused_vs_stored_feature"]["distance"] << " bits\n";
  }
  if (!have_w) std::cout << "note      no weights (run `drape calibrate`): unweighted distance only\n";
}

int RunRecognize(const RecognizeArgs& a) {
  const int nq = !a.entry.empty() + !a.sweep.empty() + !a.mesh.empty();
  if (nq != 1) throw Error("give exactly one query: --entry ID, --sweep DIR or --mesh FILE");
  if (a.seed_option->count() && !a.entry.empty() && !a.refuse)
    throw Error("--seed: only with --sweep, --mesh or --refuse (an entry's stored feature needs none)");
  if (a.no_category_fit && a.entry.empty())
    throw Error(
        "--no-category-fit: only with --entry (a sweep or mesh query keeps no reconstruction: the nearest "
        "neighbour decides its category)");
  if (a.no_category_fit && !a.category.empty())
    throw Error("--no-category-fit and --category: a given category is not decided at all");
  const OptionsFile file = OptionsFile::LoadIfGiven(a.config);
  MatchingKnobs matching;
  kMatchingSection.Read(file, matching);
  RecognizeKnobs knobs;
  kRecognizeSection.Read(file, knobs);
  ReleaseQueryOptions qo;
  kCategoryFitSection.Read(file, qo.fit);
  qo.fit.threads = 0;  // all cores; the same decision for any count
  qo.category_fit = !a.no_category_fit;
  qo.recognize.top_k = a.top_k;
  qo.recognize.category = a.category;
  if (!knobs.instance.empty()) qo.recognize.instances = {knobs.instance};

  auto t0 = Clock::now();
  const Release rel = Release::Open(a.release);
  LoadReport lr;
  const Database db = LoadDatabase(rel, &lr, matching.Parsed());
  const double load_s = Since(t0);
  std::optional<Weights> w;
  const fs::path wpath = LoadWeightsFor(rel, a.weights, w);

  ReleaseQuery q;
  q.kind = !a.entry.empty()   ? ReleaseQuery::Kind::kEntry
           : !a.sweep.empty() ? ReleaseQuery::Kind::kSweep
                              : ReleaseQuery::Kind::kMesh;
  q.value = !a.entry.empty() ? a.entry : !a.sweep.empty() ? a.sweep : a.mesh;
  q.seed = a.seed;
  q.refuse = a.refuse;
  ReleaseQueryResult r = RecognizeReleaseQuery(rel, db, w ? &*w : nullptr, q, qo);
  r.timing["load_database_seconds"] = load_s;

  Json out = r.ToJson(db);
  out["release"] = rel.dir().string();
  out["digest"] = rel.digest();
  out["weights"] = wpath.empty() ? Json(nullptr) : Json(wpath.string());
  out["database"] = {{"entries", db.size()}, {"kernel", KernelName(db.matcher().kernel())}};
  if (a.json) {
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  PrintRecognition(r.query, r.timing, r.recognition, db, r.anchor_hung, w.has_value());
  return 0;
}

Runner SetupRecognize(CLI::App& app) {
  auto a = std::make_shared<RecognizeArgs>();
  app.footer(kRecognizeFooter);
  app.add_option("RELEASE", a->release, "the release (its train split is the database)")->required();
  CLI::Option* entry =
      app.add_option("--entry", a->entry, "query: a release entry (usually from the test split)")->type_name("ID");
  app.add_option("--sweep", a->sweep, "query: a recorded sweep folder (16-bit depth PNGs in mm + cameras.json)")
      ->type_name("DIR");
  app.add_option("--mesh", a->mesh, "query: a hung mesh in the object frame (gripper at the origin, y up)")
      ->type_name("FILE");
  AddWeights(app, a->weights);
  app.add_option("--category", a->category, "the category is known: search only its entries")->type_name("C");
  AddCount(app, "--top-k", a->top_k, "distinct anchors listed");
  a->seed_option = AddSeed(app, a->seed, "seed of a sweep's fusion or a mesh's synthetic sweep");
  app.add_flag("--refuse", a->refuse, "with --entry: also re-fuse the entry's kept sweep, time it and compare")
      ->needs(entry);
  app.add_flag("--no-category-fit", a->no_category_fit,
               "the category by the unweighted nearest neighbour, not by registration (docs/recognition.md)");
  AddJson(app, a->json);
  AddConfig(app, a->config);
  return [a] { return RunRecognize(*a); };
}

// ------------------------------------------------------------------ calibrate

const char* kCalibrateFooter =
    "Learns the weighted Hamming distance (paper Eq. learn), one weight vector per category, with\n"
    "a RankSVM solved by the cutting-plane method (dlib svm_rank_trainer): for every calibration\n"
    "query, database entries with its anchor must rank closer than the others. Writes\n"
    "RELEASE/calibration/weights.json + weights.bin, tied to the release digest (outside\n"
    "SHA256SUMS and the digest).\n"
    "\n"
    "By default the RankSVM is regularised towards the unweighted distance, w = 1 + δ with ½‖δ‖²\n"
    "penalised, and the weight tying and C are chosen by leave-one-garment-instance-out\n"
    "cross-validation on the calibration and train queries (one-standard-error rule; the\n"
    "unweighted distance, C = 0, is a candidate and wins when no learned setting is clearly\n"
    "better); the height gates on the hung height are chosen on the same queries. The test split\n"
    "is never read. A fixed setting is the options file's `calibrate` section. See\n"
    "docs/recognition.md, \"Learned weights that carry over\".";

struct CalibrateArgs {
  std::string release, output, split, config;
  bool paper = false, no_height_gates = false, json = false;
};

// The summary drape calibrate prints: the setting, one line per category, the height gates.
void PrintCalibration(const Release& rel, const Database& db, const std::vector<LabelledCode>& queries,
                      const std::string& split, const CalibrateOptions& opt, double secs,
                      const CalibrationResult& res) {
  std::cout << "calibrated " << rel.dir().string() << " (" << db.size() << " database entries, " << queries.size()
            << " " << split << " queries, "
            << (opt.c == 0 ? std::string("C = 0: w = 1, the unweighted distance")
                           : "C = " + FormatNumber(opt.c) + ", " + RegularizerName(opt.regularizer) + " prior, " +
                                 WeightTyingName(opt.tying) + " weights")
            << ", frame " << WeightFrameName(opt.frame) << ") in " << Fmt("%.2f", secs) << " s\n";
  std::cout << "category              queries skipped   pairs  pair-acc u→l   calib top-1 u→l   nonzero w  "
               "mean |w−1|  clipped\n";
  for (const auto& c : res.categories) {
    char line[256];
    std::snprintf(line, sizeof line,
                  "%-20s %8d %7d %7lld  %5.3f → %5.3f   %3d → %3d of %-3d   %5.1f %%    %6.3f   %6d\n",
                  c.category.c_str(), c.queries, c.skipped, c.pairs, c.accuracy_before, c.accuracy_after, c.top1_before,
                  c.top1_after, c.queries, 100 * c.nonzero_fraction, c.mean_abs_departure, c.clipped);
    std::cout << line;
  }
  if (opt.height_gates && res.gates.queries > 0) {
    const GateSelection& g = res.gates;
    std::cout << "height gates (" << g.queries
              << " selection queries): category τ = " << FormatNumber(g.chosen.category)
              << ", pose τ = " << FormatNumber(g.chosen.pose) << " (right answers per τ: ";
    for (size_t k = 0; k < g.taus.size(); ++k) {
      std::cout << (k ? ", " : "") << FormatNumber(g.taus[k]) << ": " << g.category_right[k] << "/" << g.pose_right[k];
    }
    std::cout << "; τ 0 = none)\n";
  }
}

int RunCalibrate(const CalibrateArgs& a) {
  CalibrateKnobs knobs;
  kCalibrateSection.Read(OptionsFile::LoadIfGiven(a.config), knobs);
  const bool paper = a.paper;
  if (paper && (knobs.c >= 0 || !knobs.regularize.empty() || !knobs.tie.empty()))
    throw Error(
        "--paper fixes C, the regulariser and the tying; drop calibrate.c/regularize/tie from the options file");
  const Release rel = Release::Open(a.release);
  CalibrateOptions opt;
  opt.regularizer =
      paper ? Regularizer::kZero : ParseRegularizer(knobs.regularize.empty() ? "uniform" : knobs.regularize);
  opt.tying = paper ? WeightTying::kBit : ParseWeightTying(knobs.tie.empty() ? "annulus" : knobs.tie);
  opt.c = paper ? 10.0 : knobs.c >= 0 ? knobs.c : 10.0;
  const bool cross_validate = !paper && knobs.c < 0;
  opt.epsilon = knobs.epsilon;
  opt.frame = ParseWeightFrame(knobs.frame);
  opt.height_gates = !a.no_height_gates;
  if (cross_validate) opt.c = 1;  // validated below with the chosen value
  opt.Validate();
  const std::string split = !a.split.empty() ? a.split : paper ? "calibration" : "calibration,train";
  LoadReport lr;
  const Database db = LoadDatabase(rel, &lr);
  LoadReport qr;
  std::vector<LabelledCode> queries;
  for (const std::string& s : SplitList(split)) {
    std::vector<LabelledCode> q = LoadSplit(rel, s, &qr);
    if (q.empty()) throw Error("calibrate: split '" + s + "' of " + rel.dir().string() + " has no usable entries");
    queries.insert(queries.end(), std::make_move_iterator(q.begin()), std::make_move_iterator(q.end()));
  }
  std::optional<CrossValidation> cv;
  if (cross_validate) {
    const auto tcv = Clock::now();
    const HeightGates gates = opt.height_gates ? SelectHeightGates(db, queries, opt).chosen : HeightGates{};
    cv = CrossValidate(db, queries, opt, gates, DefaultCvGrid());
    if (cv->chosen < 0) throw Error("calibrate: cross-validation had no held-out query (too few garment instances)");
    const CvSetting& ch = cv->settings[cv->chosen];
    opt.c = ch.c;
    opt.regularizer = ch.regularizer;
    opt.tying = ch.tying;
    if (!a.json) {
      std::cout << "cross-validation (leave one garment instance out, " << cv->folds << " folds, " << cv->queries
                << " held-out queries, " << Fmt("%.1f", Since(tcv)) << " s): right anchors per setting\n";
      for (size_t k = 0; k < cv->settings.size(); ++k) {
        const CvSetting& s = cv->settings[k];
        std::cout << (int(k) == cv->chosen ? "  * " : "    ") << s.Name() << ": " << s.right << "/" << cv->queries;
        for (const auto& [c, n] : s.right_by_category)
          std::cout << "  " << c << " " << n << "/" << cv->queries_by_category[c];
        std::cout << (s.eligible ? "" : "  (reported only)") << "\n";
      }
    }
  }
  const auto t0 = Clock::now();
  CalibrationResult res = Calibrate(db, queries, opt, rel.digest());
  const double secs = Since(t0);
  res.weights.options["split"] = split;
  res.weights.options["setting"] = paper ? "paper" : cross_validate ? "cross-validated" : "fixed";
  if (cv) res.weights.stats["cross_validation"] = ToJson(*cv);
  res.weights.stats["seconds"] = secs;
  res.weights.stats["database_entries"] = db.size();
  res.weights.stats["queries"] = static_cast<int>(queries.size());
  res.weights.stats["release"] = {{"name", rel.dataset().value("name", "")},
                                  {"version", rel.dataset().value("version", "")}};
  const fs::path out = !a.output.empty() ? fs::path(a.output) : DefaultWeightsDir(rel);
  SaveWeights(res.weights, out);
  if (a.json) {
    std::cout << Json{{"weights", (out / "weights.json").string()}, {"stats", res.weights.stats}}.dump(2) << "\n";
    return 0;
  }
  PrintCalibration(rel, db, queries, split, opt, secs, res);
  for (const auto& wmsg : res.warnings) std::cout << "warning: " << wmsg << "\n";
  std::cout << "wrote " << (out / "weights.json").string() << " + weights.bin (release digest "
            << rel.digest().substr(0, 12) << "…)\n";
  return 0;
}

Runner SetupCalibrate(CLI::App& app) {
  auto a = std::make_shared<CalibrateArgs>();
  app.footer(kCalibrateFooter);
  app.add_option("RELEASE", a->release, "the release")->required();
  AddOutput(app, a->output, "write weights.json + weights.bin into this folder (default RELEASE/calibration)");
  app.add_option("--split", a->split,
                 "split(s) to learn from (default calibration,train; --paper: calibration); a query is ranked "
                 "against the database entries of other garment instances only")
      ->type_name("S[,S2]");
  app.add_flag("--paper", a->paper,
               "the paper's setting: plain RankSVM (½‖w‖², w >= 0), one weight per bit, C = 10, calibration "
               "split only, no cross-validation");
  app.add_flag("--no-height-gates", a->no_height_gates, "learn no height gates (the paper's Algorithm 1 alone)");
  AddJson(app, a->json);
  AddConfig(app, a->config);
  return [a] { return RunCalibrate(*a); };
}

// ------------------------------------------------------------------ eval

const char* kEvalFooter =
    "Pose recognition on a split, as the paper's table: per category, pose accuracy with each\n"
    "database instance and all, unweighted vs learned distance; category accuracy; top-k;\n"
    "grasp-point error (cm, on the flat pattern); time per query (fusion and feature from the\n"
    "build's timing record, matching measured here). Then the registration table (each test\n"
    "entry's database mesh registered onto its recon.ply: S->T, T->S for R and R+N, anchor\n"
    "transfer error) and the category by registration beside the nearest neighbour's (~4 CPU-s\n"
    "per query). A recipe with a miss curve (splits test_miss_<mm>mm) adds its table: strict and\n"
    "twin-credited pose accuracy per category at each grasp miss, beside the test split.\n"
    "A release with hangs_per_anchor K > 1 adds the K curve: the same figures with a database\n"
    "of each anchor's first K' hangs, K' = 1, 2, 4, ... and K.\n"
    "--ladder adds the same tables on every test_<rung> split of the recipe\n"
    "(e.g. recipes/quickstart_ladder.yaml) and figures of the worst confusions.";

struct EvalArgs {
  std::string release, split = "test", output, weights, config;
  int top_k = 3, jobs = 0;
  bool json = false, ladder = false, no_registration = false, no_category_fit = false;
};

// Each split's evaluation, run once: the evaluated split's own result (`res`) and the
// others on first use (the miss curve's levels are also ladder rungs); null when the
// split has no usable entries.
class SplitEvals {
 public:
  SplitEvals(const Release& rel, const Database& db, const Weights* w, const EvalOptions& eo, const std::string& split,
             const EvalResult& res)
      : rel_(rel), db_(db), w_(w), eo_(eo), split_(split), res_(res) {}
  const EvalResult* Get(const std::string& split) {
    if (split == split_) return &res_;
    auto it = done_.find(split);
    if (it == done_.end()) {
      LoadReport lr;
      const std::vector<EvalQuery> q = LoadEvalQueries(rel_, split, &lr);
      std::optional<EvalResult> r;
      if (!q.empty()) r = Evaluate(db_, w_, q, AnchorUvs(rel_), eo_);
      it = done_.emplace(split, std::move(r)).first;
    }
    return it->second ? &*it->second : nullptr;
  }

 private:
  const Release& rel_;
  const Database& db_;
  const Weights* w_;
  const EvalOptions& eo_;
  const std::string& split_;
  const EvalResult& res_;
  std::map<std::string, std::optional<EvalResult>> done_;
};

// The ablation ladder: every rung's split evaluated like the evaluated split, the table
// into res.report["ladder"], figures into the report folder.
void RunLadder(const Release& rel, const std::optional<Recipe>& recipe, const Database& db, SplitEvals& evals,
               EvalResult& res, const std::optional<std::string>& dir) {
  const std::vector<LadderRung> rungs = recipe ? LadderRungs(rel, *recipe) : std::vector<LadderRung>{};
  if (rungs.empty()) throw Error("eval --ladder: the release's recipe has no test_<rung> split with entries");
  std::vector<LadderResult> results;
  for (const LadderRung& rung : rungs) {
    if (const EvalResult* r = evals.Get(rung.split)) results.push_back({rung, *r});
  }
  res.report["ladder"] = LadderTable(results);
  if (dir) {
    fs::create_directories(*dir);
    res.report["ladder_figures"] = WriteWorstConfusions(rel, db, results, *dir);
  }
}

// The miss curve (recipes with `miss_curve`) into res.report["miss_curve"], the test
// split as its headline when it is the evaluated split.
void RunMissCurve(const Release& rel, const std::optional<Recipe>& recipe, SplitEvals& evals, const std::string& split,
                  EvalResult& res) {
  if (!recipe) return;
  const std::vector<MissLevel> levels = MissCurveLevels(rel, *recipe);
  if (levels.empty()) return;
  std::vector<MissPoint> points;
  for (const MissLevel& l : levels)
    if (const EvalResult* r = evals.Get(l.split)) points.push_back({l, *r});
  res.report["miss_curve"] = MissCurveTable(split == "test" ? &res : nullptr, DescribeTestSplit(*recipe), points);
}

// The category by registration and its selection into res.report.
void RunCategoryFit(const EvalArgs& a, const EvalKnobs& knobs, const CategoryFitOptions& o, const Release& rel,
                    const Database& db, const Weights* w, const std::vector<EvalQuery>& queries, EvalResult& res) {
  if (!a.no_category_fit) {
    if (!a.json) std::cout << "category by registration...\n" << std::flush;
    res.report["category_fit"] = EvaluateCategoryFit(rel, db, w, queries, o);
  }
  if (knobs.category_fit_selection) {
    if (!a.json) std::cout << "category by registration: selection on train + calibration...\n" << std::flush;
    LoadReport cr;
    const std::vector<LabelledCode> calibration = LoadSplit(rel, "calibration", &cr);
    res.report["category_fit_selection"] =
        SelectCategoryFit(rel, db, w ? w->height_gates.category : 0, calibration, o.threads);
  }
}

int RunEval(const EvalArgs& a) {
  const OptionsFile file = OptionsFile::LoadIfGiven(a.config);
  MatchingKnobs matching;
  kMatchingSection.Read(file, matching);
  EvalKnobs knobs;
  kEvalSection.Read(file, knobs);
  CategoryFitOptions fit;
  kCategoryFitSection.Read(file, fit);
  fit.threads = a.jobs;
  RegistrationEvalOptions ro;
  kRegistrationSection.Read(file, ro.registration);
  ro.max_pairs_per_category = knobs.registration_pairs;
  ro.threads = a.jobs;
  ro.Validate();
  const std::optional<std::string> report_dir = a.output.empty() ? std::nullopt : std::optional(a.output);

  const Release rel = Release::Open(a.release);
  const std::string& split = a.split;
  auto t0 = Clock::now();
  LoadReport lr;
  const Database db = LoadDatabase(rel, &lr, matching.Parsed());
  const double load_s = Since(t0);
  LoadReport qr;
  const std::vector<EvalQuery> queries = LoadEvalQueries(rel, split, &qr);
  if (queries.empty()) throw Error("eval: split '" + split + "' of " + rel.dir().string() + " has no usable entries");
  std::optional<Weights> w;
  const fs::path wpath = LoadWeightsFor(rel, a.weights, w);
  const Weights* wp = w ? &*w : nullptr;
  EvalOptions eo;
  eo.top_k = a.top_k;
  EvalResult res = Evaluate(db, wp, queries, AnchorUvs(rel), eo);
  std::vector<std::string> warnings = lr.warnings;
  warnings.insert(warnings.end(), qr.warnings.begin(), qr.warnings.end());
  Json header{{"release", rel.dir().string()},
              {"name", rel.dataset().value("name", "")},
              {"version", rel.dataset().value("version", "")},
              {"digest", rel.digest()},
              {"split", split},
              {"weights", wpath.empty() ? Json("none (unweighted only)") : Json(wpath.string())},
              {"calibration", w ? Json{{"options", w->options}, {"stats", w->stats}} : Json(nullptr)},
              {"database_load_seconds", load_s},
              {"load_warnings", warnings},
              {"provenance", RunProvenance()}};
  if (!a.no_registration) {
    if (!a.json) std::cout << "registering test entries (pose known)...\n" << std::flush;
    RegistrationEvalResult rr = EvaluateRegistration(rel, db, res.report["per_query"], split, ro);
    if (report_dir) {
      fs::create_directories(*report_dir);
      rr.table["figures"] = WriteRegistrationFigures(rr, *report_dir);
    }
    res.report["registration"] = rr.table;
  }
  SplitEvals evals(rel, db, wp, eo, split, res);
  // The recipe only when a table needs it: an older release's recipe may not parse today.
  std::optional<Recipe> recipe;
  if (a.ladder || HasMissSplits(rel)) recipe = ReleaseRecipe(rel);  // nullopt: the release records none
  RunMissCurve(rel, recipe, evals, split, res);
  if (HangsPerAnchor(db) > 1)
    res.report["k_curve"] = KCurveTable(KCurvePoints(db, wp, queries, AnchorUvs(rel), eo, res));
  if (a.ladder) RunLadder(rel, recipe, db, evals, res, report_dir);
  RunCategoryFit(a, knobs, fit, rel, db, wp, queries, res);
  if (report_dir) WriteReport(res, header, *report_dir);
  if (a.json) {
    Json full = header;
    for (const auto& [k, v] : res.report.items()) full[k] = v;
    std::cout << full.dump(2) << "\n";
    return 0;
  }
  std::cout << "eval " << rel.dir().string() << " split " << split << ": " << queries.size() << " queries, "
            << db.size()
            << " database entries, weights: " << (w ? wpath.string() : std::string("none (unweighted only)")) << "\n\n"
            << ReportMarkdown(res.report);
  if (report_dir) std::cout << "\nreport: " << (fs::path(*report_dir) / "report.md").string() << "\n";
  return 0;
}

Runner SetupEval(CLI::App& app) {
  auto a = std::make_shared<EvalArgs>();
  app.footer(kEvalFooter);
  app.add_option("RELEASE", a->release, "the release")->required();
  app.add_option("--split", a->split, "the queries' split")->type_name("S")->capture_default_str();
  AddOutput(app, a->output, "write report.md, report.json and PNG plots into this folder");
  AddWeights(app, a->weights);
  AddCount(app, "--top-k", a->top_k, "k of the top-k accuracy");
  AddJobs(app, a->jobs, "registrations run side by side (default: all cores; the same numbers for any N)");
  app.add_flag("--ladder", a->ladder,
               "also the ablation ladder: the same tables on every test_<rung> split of the recipe, one table per "
               "category, and figures of the worst confusions");
  app.add_flag("--no-registration", a->no_registration, "skip the registration table");
  app.add_flag("--no-category-fit", a->no_category_fit, "skip the category by registration");
  AddJson(app, a->json);
  AddConfig(app, a->config);
  return [a] { return RunEval(*a); };
}

Register reg_recognize({"recognize", "recognise the category and grasp point of a hung garment", SetupRecognize});
Register reg_calibrate({"calibrate", "learn the weighted Hamming distance (RankSVM) for a release", SetupCalibrate});
Register reg_eval({"eval", "evaluate pose recognition on a split and write a report", SetupEval});

}  // namespace
}  // namespace drape::cli
