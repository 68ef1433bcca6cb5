// drape recognize / calibrate / eval: pose recognition against a release (paper
// §"Pose Estimation"), RankSVM calibration of the weighted Hamming distance, and the
// evaluation report.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "cli/args.h"
#include "cli/command.h"
#include "common/error.h"
#include "common/format.h"
#include "common/timing.h"
#include "common/version.h"
#include "garments/io.h"
#include "generator/release/release.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/category_fit.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/ladder.h"
#include "runtime/recognition/query_pipeline.h"
#include "runtime/recognition/registration_eval.h"
#include "runtime/recognition/release_source.h"
#include "runtime/recognition/twin_fit.h"

namespace drape::cli {
namespace {

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

namespace fs = std::filesystem;
using namespace drape::recognition;

Kernel ParseKernel(const std::string& s) {
  if (s == "auto") return Kernel::kAuto;
  if (s == "generic") return Kernel::kGeneric;
  if (s == "popcnt") return Kernel::kPopcnt;
  if (s == "avx512") return Kernel::kAvx512;
  throw Error("--kernel: '" + s + "' is not one of auto, generic, popcnt, avx512");
}

// --weights PATH | none; default: <release>/calibration if it exists. Returns the path
// used (empty = unweighted) and fills `w`.
fs::path ResolveWeights(const Args& a, const Release& rel, Weights* w, bool* have) {
  *have = false;
  const std::string opt = a.Get("--weights", "");
  if (opt == "none" || a.Flag("--unweighted")) return {};
  fs::path p = opt.empty() ? DefaultWeightsDir(rel) / "weights.json" : fs::path(opt);
  if (opt.empty() && !fs::exists(p)) return {};
  *w = LoadWeights(p, rel.digest());
  *have = true;
  return p;
}

std::string Fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// ------------------------------------------------------------------ recognize

const char* kRecognizeUsage =
    "Usage: drape recognize RELEASE (--entry ID | --sweep DIR | --mesh FILE) [options]\n"
    "\n"
    "Recognises the category and the grasped anchor of a garment held by a gripper, by\n"
    "nearest neighbour in the release's train split (the database): the category by the\n"
    "unweighted rotation-invariant Hamming distance (paper Eq. match), the anchor inside\n"
    "that category by the learned weighted distance (Eq. bestmatch) when the release has\n"
    "weights from `drape calibrate`.\n"
    "\n"
    "Query (one of):\n"
    "  --entry ID        a release entry (usually from the test split); its stored feature\n"
    "                    is used, fusion/feature times come from the build's timing record\n"
    "                    (add --refuse to re-fuse its kept sweep and time it here)\n"
    "  --sweep DIR       a recorded sweep: 16-bit depth PNGs (mm) + cameras.json; fused and\n"
    "                    featurised with the release's recipe options\n"
    "  --mesh FILE       a hung mesh in the object frame (gripper at the origin, y up); a\n"
    "                    synthetic sweep of it is fused and featurised like a test entry\n"
    "Options:\n"
    "  --weights PATH    weights.json (default: RELEASE/calibration/weights.json if present);\n"
    "                    'none' or --unweighted for Eq. match only\n"
    "  --category C      the category is known: search only its entries\n"
    "  --instance I      search only database garment instance I\n"
    "  --top-k K         distinct anchors listed (default 5)\n"
    "  --refuse          with --entry: re-fuse the entry's kept sweep and time it\n"
    "  --seed N          seed for a mesh query's synthetic sweep (default 0)\n"
    "  --kernel K        auto | generic | popcnt | avx512 (default auto)\n"
    "  --json            machine-readable output\n"
    "  --category-fit / --no-category-fit\n"
    "                    the category by registration (docs/recognition.md, \"The category by\n"
    "                    registration\"): on by default for --entry with a recon.ply (~4 CPU-s), not\n"
    "                    available for --sweep / --mesh (no reconstruction kept: the unweighted nearest\n"
    "                    neighbour decides); settings --category-fit-k K, --category-fit-top N,\n"
    "                    --category-fit-lambda L as drape eval\n"
    "  --twin-fit        tell the matched anchor from its left/right twin by registering both hung\n"
    "                    meshes onto the entry's recon.ply and comparing them only near the\n"
    "                    front/back cue (neckline, waist; docs/recognition.md); only with --entry;\n"
    "                    settings --twin-fit-radius R, --twin-fit-direction D, --twin-fit-instances N,\n"
    "                    --twin-fit-margin M as drape eval\n";

// A release entry as the query: its stored feature (with --refuse also re-fused from its
// kept sweep and compared), described in `query`, fusion/feature times from the build.
Code EntryQuery(const Args& a, const Release& rel, const std::string& id, uint64_t seed, Json& query, Json& timing) {
  const Release::EntryInfo* e = rel.Find(id);
  if (!e) throw Error("--entry: release has no entry '" + id + "'");
  if (e->failed) throw Error("--entry: entry " + id + " failed in the build (" + e->failure + ")");
  const EntryLabel l = LabelFromEntry(*e);
  Code q = LoadEntryCode(rel, *e);
  query = {{"kind", "entry"},
           {"id", id},
           {"split", e->split},
           {"true_category", l.category},
           {"true_anchor", l.anchor},
           {"instance", l.instance},
           {"height", ReconHeight(rel, *e)}};
  if (e->split == "train") query["note"] = "a train entry is in the database: it matches itself at distance 0";
  const StageTiming st = EntryStageTiming(rel.build_info(), id);
  timing["fusion_seconds"] = st.fusion_seconds >= 0 ? Json(st.fusion_seconds) : Json(nullptr);
  timing["feature_seconds"] = st.feature_seconds >= 0 ? Json(st.feature_seconds) : Json(nullptr);
  timing["fusion_feature_source"] = st.source.empty() ? "not recorded by the build" : st.source;
  if (a.Flag("--refuse")) {
    bool has_sweep = false;
    for (const auto& f : e->files) has_sweep |= f.path == "sweep/cameras.json";
    if (!has_sweep)
      throw Error("--refuse: entry " + id + " kept no sweep (the recipe's keep_frames is off for its split)");
    const PipelineResult pr = FeatureFromSweep(rel, rel.EntryPath(id, "sweep"), seed);
    timing["refused"] = {{"read_seconds", pr.timing.read_seconds},
                         {"fusion_seconds", pr.timing.fusion_seconds},
                         {"feature_seconds", pr.timing.feature_seconds}};
    const Match m = DistanceReference(q, pr.code);
    query["refused_vs_stored_feature"] = {{"distance", m.distance}, {"rotation", m.rotation}};
  }
  return q;
}

// A recorded sweep (--sweep) or a hung mesh (--mesh) fused and featurised in this run.
Code FileQuery(const Args& a, const Release& rel, uint64_t seed, Json& query, Json& timing) {
  const bool sweep = a.Get("--sweep").has_value();
  const fs::path p = sweep ? *a.Get("--sweep") : *a.Get("--mesh");
  const PipelineResult pr = sweep ? FeatureFromSweep(rel, p, seed) : FeatureFromMesh(rel, p, seed);
  query = {{"kind", sweep ? "sweep" : "mesh"}, {"path", p.string()}, {"info", pr.info}, {"height", pr.height}};
  timing["read_seconds"] = pr.timing.read_seconds;
  if (!sweep) timing["sweep_seconds"] = pr.timing.sweep_seconds;
  timing["fusion_seconds"] = pr.timing.fusion_seconds;
  timing["feature_seconds"] = pr.timing.feature_seconds;
  timing["fusion_feature_source"] = "measured in this run";
  return pr.code;
}

CategoryFitOptions CategoryFitFromArgs(const Args& a);
std::optional<TwinFitOptions> TwinFitFromArgs(const Args& a);

// `drape recognize --category-fit`: the category decided by registering each category's
// best entries onto the entry query's recon.ply, set into `o` (when any registered).
Json RecognizeCategoryByFit(const Args& a, const Release& rel, const Database& db, const Recognizer& rec, const Code& q,
                            RecognizeOptions& o) {
  const auto id = a.Get("--entry");
  if (!id) throw Error("--category-fit needs the query's reconstruction: only with --entry");
  if (!o.category.empty()) throw Error("--category-fit and --category contradict each other");
  const CategoryFit fit = EntryCategoryByFit(rel, db, rec, q, o, *id, CategoryFitFromArgs(a));
  o.category = fit.category;
  return ToJson(fit);
}

// `drape recognize --twin-fit`: the matched anchor against its twin near the cue, onto
// entry `id`'s recon.ply; `r` takes the twin when it fits better. Null without --twin-fit.
Json RecognizeTwinByFit(const Release& rel, const Database& db, const Code& q, const RecognizeOptions& o,
                        const std::optional<std::string>& id, const std::optional<TwinFitOptions>& options,
                        Recognition& r, Json& timing) {
  if (!options) return nullptr;
  const auto t0 = Clock::now();
  Json j = ToJson(EntryTwinByFit(rel, db, q, o, id.value(), *options, r));
  j["options"] = ToJson(*options);
  timing["twin_fit_seconds"] = Since(t0);
  return j;
}

void PrintTwinFit(const Json& t) {
  std::cout << "twin fit  ";
  if (t["twin_anchor"].is_null()) {
    std::cout << "no twin of " << t["matched_anchor"].get<std::string>() << " in the database\n";
    return;
  }
  std::cout << t["matched_anchor"].get<std::string>() << " against " << t["twin_anchor"].get<std::string>();
  if (!t["matched_residual"].is_null())
    std::cout << ": cue residual " << Fmt("%.4f", t["matched_residual"].get<double>()) << " / "
              << Fmt("%.4f", t["twin_residual"].get<double>()) << " m";
  std::cout << (t["switched"].get<bool>() ? ", the twin taken" : ", kept") << " ("
            << Fmt("%.1f", t["seconds"].get<double>()) << " s)\n";
}

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

int RunRecognize(const std::vector<std::string>& argv) {
  Args a(argv, {"--json", "--unweighted", "--refuse", "--category-fit", "--no-category-fit", "--twin-fit"},
         {"--entry", "--sweep", "--mesh", "--weights", "--category", "--instance", "--top-k", "--kernel", "--seed",
          "--category-fit-k", "--category-fit-top", "--category-fit-lambda", "--twin-fit-radius",
          "--twin-fit-direction", "--twin-fit-instances", "--twin-fit-margin"});
  if (a.help()) {
    std::cout << kRecognizeUsage;
    return 0;
  }
  a.RequirePositional(1, 1, "RELEASE");
  const int nq = a.Get("--entry").has_value() + a.Get("--sweep").has_value() + a.Get("--mesh").has_value();
  if (nq != 1) throw Error("give exactly one query: --entry ID, --sweep DIR or --mesh FILE");
  if (a.Flag("--category-fit") && !a.Get("--entry"))
    throw Error("--category-fit needs the query's reconstruction: only with --entry");
  const std::optional<TwinFitOptions> twin_options = TwinFitFromArgs(a);
  if (twin_options && !a.Get("--entry")) throw Error("--twin-fit needs the query's reconstruction: only with --entry");

  auto t0 = Clock::now();
  const Release rel = Release::Open(a.positional()[0]);
  LoadReport lr;
  Database db = LoadDatabase(rel, &lr, ParseKernel(a.Get("--kernel", "auto")));
  const double load_s = Since(t0);
  Weights w;
  bool have_w = false;
  const fs::path wpath = ResolveWeights(a, rel, &w, &have_w);
  Recognizer rec(db, have_w ? &w : nullptr);

  Json query{{"kind", ""}};
  Json timing{{"load_database_seconds", load_s}};
  const uint64_t seed = a.GetSeed("--seed").value_or(0);
  const auto id = a.Get("--entry");
  const Code q = id ? EntryQuery(a, rel, *id, seed, query, timing) : FileQuery(a, rel, seed, query, timing);

  RecognizeOptions o;
  o.top_k = static_cast<int>(a.GetInt("--top-k").value_or(5));
  o.category = a.Get("--category", "");
  if (const std::string inst = a.Get("--instance", ""); !inst.empty()) o.instances = {inst};
  o.query_height = query.value("height", 0.0);
  Json fit = nullptr;
  CategoryFitFromArgs(a);  // contradictions and bad settings fail whatever the query
  // On by default where the query has a reconstruction (--entry with its recon.ply) and the
  // category is not given.
  const bool by_default =
      !a.Flag("--no-category-fit") && id && o.category.empty() && fs::exists(rel.EntryPath(*id, "recon.ply"));
  if (a.Flag("--category-fit") || by_default) {
    const auto tf = Clock::now();
    fit = RecognizeCategoryByFit(a, rel, db, rec, q, o);
    timing["category_fit_seconds"] = Since(tf);
  }
  Recognition r = rec.Recognize(q, o);
  if (!fit.is_null() && !o.category.empty()) r.category_source = "registration";
  timing["matching_seconds"] = r.match_seconds;
  const Json twin = RecognizeTwinByFit(rel, db, q, o, id, twin_options, r, timing);

  const EntryLabel& bl = db.label(r.best.entry);
  const auto hung = HungVertex(rel, bl.id, bl.anchor_vertex);
  Json out{{"release", rel.dir().string()},
           {"digest", rel.digest()},
           {"weights", wpath.empty() ? Json(nullptr) : Json(wpath.string())},
           {"query", query},
           {"result", ToJson(r)},
           {"anchor_position",
            {{"entry", bl.id},
             {"vertex", bl.anchor_vertex},
             {"hung_object_frame", hung ? Json::array({(*hung)[0], (*hung)[1], (*hung)[2]}) : Json(nullptr)},
             {"flat_uv", bl.anchor_uv ? Json::array({(*bl.anchor_uv)[0], (*bl.anchor_uv)[1]}) : Json(nullptr)}}},
           {"timing", timing},
           {"database", {{"entries", db.size()}, {"kernel", KernelName(db.matcher().kernel())}}}};
  if (!fit.is_null()) out["category_fit"] = fit;
  if (!twin.is_null()) out["twin_fit"] = twin;
  if (a.Flag("--json")) {
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  PrintRecognition(query, timing, r, db, hung, have_w);
  if (!twin.is_null()) PrintTwinFit(twin);
  return 0;
}

// ------------------------------------------------------------------ calibrate

const char* kCalibrateUsage =
    "Usage: drape calibrate RELEASE [options]\n"
    "\n"
    "Learns the weighted Hamming distance (paper Eq. learn), one weight vector per category,\n"
    "with a RankSVM solved by the cutting-plane method (dlib svm_rank_trainer): for every\n"
    "calibration query, database entries with its anchor must rank closer than the others.\n"
    "Writes RELEASE/calibration/weights.json + weights.bin, tied to the release digest\n"
    "(outside SHA256SUMS and the digest).\n"
    "\n"
    "By default the RankSVM is regularised towards the unweighted distance, w = 1 + δ with\n"
    "½‖δ‖² penalised (--regularize uniform), and the weight tying and C are chosen by\n"
    "leave-one-garment-instance-out cross-validation on the calibration and train queries\n"
    "(one-standard-error rule; the unweighted distance, C = 0, is a candidate and wins when\n"
    "no learned setting is clearly better). The test split is never read. See\n"
    "docs/recognition.md, \"Learned weights that carry over\".\n"
    "\n"
    "Options:\n"
    "  --paper           the paper's setting: plain RankSVM (½‖w‖², w >= 0), one weight per\n"
    "                    bit, C = 10, calibration split only, no cross-validation\n"
    "  --c C             fixed RankSVM penalty instead of cross-validation (dlib scales it by\n"
    "                    1/#pairs; with the uniform prior C = 0 gives w = 1)\n"
    "  --regularize R    uniform (default): ½‖w − 1‖², negative weights set to 0 afterwards;\n"
    "                    zero: ½‖w‖² with w >= 0 (the paper's)\n"
    "  --tie T           bit | annulus (one weight per layer × ring, shared by the sectors)\n"
    "                    | layer; with --c (default annulus), else cross-validated\n"
    "  --split S[,S2]    split(s) to learn from (default calibration,train; --paper:\n"
    "                    calibration); a query is ranked against the database entries of\n"
    "                    OTHER garment instances only, so train works too\n"
    "  --frame F         database (default) | query: which frame w indexes (see docs)\n"
    "  --epsilon E       solver tolerance (default 0.001)\n"
    "  --no-height-gates learn no height gates (the paper's Algorithm 1 alone). By default\n"
    "                    the gates on the hung height (docs/recognition.md) are chosen on\n"
    "                    the given split(s) and the train entries (vs other instances)\n"
    "  --out DIR         write the weights here instead\n"
    "  --json            print the training statistics as JSON\n";

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

int RunCalibrate(const std::vector<std::string>& argv) {
  Args a(argv, {"--json", "--no-height-gates", "--paper"},
         {"--c", "--split", "--frame", "--epsilon", "--out", "--regularize", "--tie"});
  if (a.help()) {
    std::cout << kCalibrateUsage;
    return 0;
  }
  a.RequirePositional(1, 1, "RELEASE");
  const Release rel = Release::Open(a.positional()[0]);
  const bool paper = a.Flag("--paper");
  if (paper && (a.Get("--c") || a.Get("--regularize") || a.Get("--tie"))) {
    throw Error("calibrate: --paper fixes C, the regulariser and the tying; drop --c/--regularize/--tie");
  }
  CalibrateOptions opt;
  opt.regularizer = paper ? Regularizer::kZero : ParseRegularizer(a.Get("--regularize", "uniform"));
  opt.tying = paper ? WeightTying::kBit : ParseWeightTying(a.Get("--tie", "annulus"));
  opt.c = paper ? 10.0 : a.GetDouble("--c").value_or(10.0);
  const bool cross_validate = !paper && !a.Get("--c");
  if (cross_validate && (a.Get("--regularize") || a.Get("--tie"))) {
    throw Error("calibrate: --regularize/--tie go with --c (without it both are cross-validated)");
  }
  opt.epsilon = a.GetDouble("--epsilon").value_or(0.001);
  opt.frame = ParseWeightFrame(a.Get("--frame", "database"));
  opt.height_gates = !a.Flag("--no-height-gates");
  if (cross_validate) opt.c = 1;  // validated below with the chosen value
  opt.Validate();
  const std::string split = a.Get("--split", paper ? "calibration" : "calibration,train");
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
    if (!a.Flag("--json")) {
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
  const fs::path out = a.Get("--out") ? fs::path(*a.Get("--out")) : DefaultWeightsDir(rel);
  SaveWeights(res.weights, out);
  if (a.Flag("--json")) {
    std::cout << Json{{"weights", (out / "weights.json").string()}, {"stats", res.weights.stats}}.dump(2) << "\n";
    return 0;
  }
  PrintCalibration(rel, db, queries, split, opt, secs, res);
  for (const auto& wmsg : res.warnings) std::cout << "warning: " << wmsg << "\n";
  std::cout << "wrote " << (out / "weights.json").string() << " + weights.bin (release digest "
            << rel.digest().substr(0, 12) << "…)\n";
  return 0;
}

// ------------------------------------------------------------------ eval

const char* kEvalUsage =
    "Usage: drape eval RELEASE [--split test] [--report DIR] [options]\n"
    "\n"
    "Pose recognition on a split, as the paper's table: per category, pose accuracy with\n"
    "database instance 1 only, instance 2 only and both, unweighted vs learned distance;\n"
    "category accuracy; top-3; grasp-point error (cm, on the flat pattern); time per query\n"
    "(fusion and feature from the build's timing record, matching measured here).\n"
    "\n"
    "Options:\n"
    "  --split S         queries (default test)\n"
    "  --report DIR      write report.md, report.json and PNG plots there\n"
    "  --weights PATH    weights.json (default RELEASE/calibration/weights.json if present)\n"
    "  --unweighted      ignore weights\n"
    "  --top-k K         k of the top-k accuracy (default 3)\n"
    "  --kernel K        auto | generic | popcnt | avx512\n"
    "  --json            print report.json to stdout\n"
    "  --ladder          also the ablation ladder: the same tables on every test_<rung> split of the\n"
    "                    recipe (test-split variants, e.g. recipes/quickstart_ladder.yaml), one table\n"
    "                    per category, and figures of the worst confusions (ladder_*.png)\n"
    "\n"
    "Registration table (paper's Table \"Registration results\"; on by default):\n"
    "  --registration / --no-registration\n"
    "                    register each test entry's database mesh (train hang.ply of the true\n"
    "                    category and anchor) to its recon.ply: S->T, T->S for R and R+N, anchor\n"
    "                    transfer error (cm), time; figures registration_<category>.png\n"
    "  --registration-pairs N   at most N pairs per category (default 0 = all)\n"
    "  --threads N       pairs registered in parallel (default: all cores; same numbers for any N)\n"
    "\n"
    "Category by registration (docs/recognition.md, \"The category by registration\"; on by default):\n"
    "  --category-fit / --no-category-fit\n"
    "                    also decide each query's category by registering the best database entries of\n"
    "                    the nearest categories (hang.ply, scale + ICP) onto its recon.ply and taking the\n"
    "                    best fit; reported beside the unweighted nearest neighbour, with the end-to-end\n"
    "                    pose (~4 CPU-s per query)\n"
    "  --category-fit-k K        entries registered per category (default 2)\n"
    "  --category-fit-top N      only the N nearest categories by Hamming (default 2; 0 = all in the gate)\n"
    "  --category-fit-lambda L   weight of the Hamming distance in the score (default 0 = the fit alone)\n"
    "  --category-fit-selection  choose those settings on train + calibration: the calibration split and\n"
    "                    every train entry against the other instances, a grid of settings counted\n"
    "                    (report.json \"category_fit_selection\"); never reads the test split\n"
    "\n"
    "Twins by the cue's fit (docs/recognition.md, \"Twins told apart by the cue's fit\"; off by default):\n"
    "  --twin-fit        after the pose match (category known, every instance), register the matched\n"
    "                    entry and its left/right twin of the same instance onto the query's recon.ply\n"
    "                    and take the one that fits better near the front/back cue (the neckline's\n"
    "                    anchors for shirts, the waist's for trousers); strict pose before / after\n"
    "                    (report.json \"twin_fit\"; ~2 CPU-s per query with a twin)\n"
    "  --twin-fit-radius R       the cue region: within R m of the cue anchors (default 0.16)\n"
    "  --twin-fit-direction D    db (mesh near the cue to recon) | recon (recon near the cue to the\n"
    "                    mesh) | both (their mean) | db_signed | recon_signed (default) | signed: the\n"
    "                    same signed along recon's outward normal | whole (the whole shapes)\n"
    "  --twin-fit-instances N    1: the matched entry's instance (default); 0: every instance, summed\n"
    "  --twin-fit-margin M       take the twin only when its residual is below (1 - M) times the\n"
    "                    matched one's (signed: by M times the matched unsigned residual; default\n"
    "                    0.05); defaults: the most right on train + calibration of paper 2.3.0\n"
    "  --twin-fit-selection      choose those settings on train + calibration (as\n"
    "                    --category-fit-selection; report.json \"twin_fit_selection\"); never reads\n"
    "                    the test split\n";

// The ablation ladder: every rung's split evaluated like `split` (whose result is
// reused), the table into res.report["ladder"], figures into the report folder.
void RunLadder(const Release& rel, const Database& db, const Weights* w, const EvalOptions& eo,
               const std::string& split, EvalResult& res, const std::optional<std::string>& dir) {
  const std::vector<LadderRung> rungs = LadderRungs(rel);
  if (rungs.empty()) throw Error("eval --ladder: the release's recipe has no test_<rung> split with entries");
  std::vector<LadderResult> results;
  for (const LadderRung& rung : rungs) {
    if (rung.split == split) {
      results.push_back({rung, res});
      continue;
    }
    LoadReport lr;
    const std::vector<EvalQuery> q = LoadEvalQueries(rel, rung.split, &lr);
    if (q.empty()) continue;
    results.push_back({rung, Evaluate(db, w, q, AnchorUvs(rel), eo)});
  }
  res.report["ladder"] = LadderTable(results);
  if (dir) {
    fs::create_directories(*dir);
    res.report["ladder_figures"] = WriteWorstConfusions(rel, db, results, *dir);
  }
}

// --category-fit-k/-top/-lambda and --threads; throws drape::Error for bad values and
// contradicting flags.
CategoryFitOptions CategoryFitFromArgs(const Args& a) {
  if (a.Flag("--category-fit") && a.Flag("--no-category-fit"))
    throw Error("--category-fit and --no-category-fit contradict each other");
  if (a.Flag("--no-category-fit") &&
      (a.Get("--category-fit-k") || a.Get("--category-fit-top") || a.Get("--category-fit-lambda")))
    throw Error("--category-fit-k/-top/-lambda contradict --no-category-fit");
  CategoryFitOptions o;
  o.per_category = static_cast<int>(a.GetInt("--category-fit-k").value_or(o.per_category));
  o.top_categories = static_cast<int>(a.GetInt("--category-fit-top").value_or(o.top_categories));
  o.bits_weight = a.GetDouble("--category-fit-lambda").value_or(o.bits_weight);
  o.threads = static_cast<int>(a.GetInt("--threads").value_or(0));
  o.Validate();
  return o;
}

// --twin-fit and its settings; nullopt without --twin-fit (settings alone are an error).
// Throws drape::Error for bad values.
std::optional<TwinFitOptions> TwinFitFromArgs(const Args& a) {
  const bool settings = a.Get("--twin-fit-radius") || a.Get("--twin-fit-direction") || a.Get("--twin-fit-instances") ||
                        a.Get("--twin-fit-margin");
  if (!a.Flag("--twin-fit")) {
    if (settings) throw Error("--twin-fit-radius/-direction/-instances/-margin need --twin-fit");
    return std::nullopt;
  }
  TwinFitOptions o;
  o.radius = a.GetDouble("--twin-fit-radius").value_or(o.radius);
  if (const auto d = a.Get("--twin-fit-direction")) o.direction = ParseTwinDirection(*d);
  o.instances = static_cast<int>(a.GetInt("--twin-fit-instances").value_or(o.instances));
  o.margin = a.GetDouble("--twin-fit-margin").value_or(o.margin);
  o.threads = static_cast<int>(a.GetInt("--threads").value_or(0));
  o.Validate();
  return o;
}

// `drape eval --twin-fit` / `--twin-fit-selection` into res.report.
void RunTwinFit(const Args& a, const Release& rel, const Database& db, const Weights* w,
                const std::vector<EvalQuery>& queries, EvalResult& res) {
  if (const std::optional<TwinFitOptions> o = TwinFitFromArgs(a)) {
    if (!a.Flag("--json")) std::cout << "twins by the cue's fit...\n" << std::flush;
    res.report["twin_fit"] = EvaluateTwinFit(rel, db, w, queries, *o);
  }
  if (a.Flag("--twin-fit-selection")) {
    if (!a.Flag("--json")) std::cout << "twins by the cue's fit: selection on train + calibration...\n" << std::flush;
    LoadReport cr;
    const std::vector<LabelledCode> calibration = LoadSplit(rel, "calibration", &cr);
    res.report["twin_fit_selection"] =
        SelectTwinFit(rel, db, w, calibration, static_cast<int>(a.GetInt("--threads").value_or(0)));
  }
}

// `drape eval --category-fit` / `--category-fit-selection` into res.report.
void RunCategoryFit(const Args& a, const Release& rel, const Database& db, const Weights* w,
                    const std::vector<EvalQuery>& queries, EvalResult& res) {
  const CategoryFitOptions o = CategoryFitFromArgs(a);
  if (!a.Flag("--no-category-fit")) {
    if (!a.Flag("--json")) std::cout << "category by registration...\n" << std::flush;
    res.report["category_fit"] = EvaluateCategoryFit(rel, db, w, queries, o);
  }
  if (a.Flag("--category-fit-selection")) {
    if (!a.Flag("--json")) std::cout << "category by registration: selection on train + calibration...\n" << std::flush;
    LoadReport cr;
    const std::vector<LabelledCode> calibration = LoadSplit(rel, "calibration", &cr);
    res.report["category_fit_selection"] =
        SelectCategoryFit(rel, db, w ? w->height_gates.category : 0, calibration, o.threads);
  }
}

int RunEval(const std::vector<std::string>& argv) {
  Args a(argv,
         {"--json", "--unweighted", "--registration", "--no-registration", "--ladder", "--category-fit",
          "--no-category-fit", "--category-fit-selection", "--twin-fit", "--twin-fit-selection"},
         {"--split", "--report", "--weights", "--top-k", "--kernel", "--registration-pairs", "--threads",
          "--category-fit-k", "--category-fit-top", "--category-fit-lambda", "--twin-fit-radius",
          "--twin-fit-direction", "--twin-fit-instances", "--twin-fit-margin"});
  if (a.Flag("--registration") && a.Flag("--no-registration")) {
    throw Error("eval: --registration and --no-registration contradict each other");
  }
  if (a.help()) {
    std::cout << kEvalUsage;
    return 0;
  }
  a.RequirePositional(1, 1, "RELEASE");
  TwinFitFromArgs(a);  // bad settings fail before any work
  const Release rel = Release::Open(a.positional()[0]);
  const std::string split = a.Get("--split", "test");
  auto t0 = Clock::now();
  LoadReport lr;
  const Database db = LoadDatabase(rel, &lr, ParseKernel(a.Get("--kernel", "auto")));
  const double load_s = Since(t0);
  LoadReport qr;
  const std::vector<EvalQuery> queries = LoadEvalQueries(rel, split, &qr);
  if (queries.empty()) throw Error("eval: split '" + split + "' of " + rel.dir().string() + " has no usable entries");
  Weights w;
  bool have_w = false;
  const fs::path wpath = ResolveWeights(a, rel, &w, &have_w);
  EvalOptions eo;
  eo.top_k = static_cast<int>(a.GetInt("--top-k").value_or(3));
  EvalResult res = Evaluate(db, have_w ? &w : nullptr, queries, AnchorUvs(rel), eo);
  std::vector<std::string> warnings = lr.warnings;
  warnings.insert(warnings.end(), qr.warnings.begin(), qr.warnings.end());
  Json header{{"release", rel.dir().string()},
              {"name", rel.dataset().value("name", "")},
              {"version", rel.dataset().value("version", "")},
              {"digest", rel.digest()},
              {"split", split},
              {"weights", wpath.empty() ? Json("none (unweighted only)") : Json(wpath.string())},
              {"calibration", have_w ? Json{{"options", w.options}, {"stats", w.stats}} : Json(nullptr)},
              {"database_load_seconds", load_s},
              {"load_warnings", warnings},
              {"provenance", RunProvenance()}};
  if (!a.Flag("--no-registration")) {
    RegistrationEvalOptions ro;
    ro.max_pairs_per_category = static_cast<int>(a.GetInt("--registration-pairs").value_or(0));
    ro.threads = static_cast<int>(a.GetInt("--threads").value_or(0));
    if (!a.Flag("--json")) std::cout << "registering test entries (pose known)...\n" << std::flush;
    RegistrationEvalResult rr = EvaluateRegistration(rel, db, res.report["per_query"], split, ro);
    if (auto dir = a.Get("--report")) {
      fs::create_directories(*dir);
      rr.table["figures"] = WriteRegistrationFigures(rr, *dir);
    }
    res.report["registration"] = rr.table;
  }
  if (a.Flag("--ladder")) RunLadder(rel, db, have_w ? &w : nullptr, eo, split, res, a.Get("--report"));
  RunCategoryFit(a, rel, db, have_w ? &w : nullptr, queries, res);
  RunTwinFit(a, rel, db, have_w ? &w : nullptr, queries, res);
  if (auto dir = a.Get("--report")) {
    WriteReport(res, header, *dir);
  }
  if (a.Flag("--json")) {
    Json full = header;
    for (const auto& [k, v] : res.report.items()) full[k] = v;
    std::cout << full.dump(2) << "\n";
    return 0;
  }
  std::cout << "eval " << rel.dir().string() << " split " << split << ": " << queries.size() << " queries, "
            << db.size()
            << " database entries, weights: " << (have_w ? wpath.string() : std::string("none (unweighted only)"))
            << "\n\n"
            << ReportMarkdown(res.report);
  if (auto dir = a.Get("--report")) std::cout << "\nreport: " << (fs::path(*dir) / "report.md").string() << "\n";
  return 0;
}

Register reg_recognize({"recognize", "recognise the category and grasp point of a hung garment", kRecognizeUsage,
                        RunRecognize});
Register reg_calibrate({"calibrate", "learn the weighted Hamming distance (RankSVM) for a release", kCalibrateUsage,
                        RunCalibrate});
Register reg_eval({"eval", "evaluate pose recognition on a split and write a report", kEvalUsage, RunEval});

}  // namespace
}  // namespace drape::cli
