#include "runtime/recognition/calibrate.h"

#include <dlib/svm.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "common/error.h"
#include "common/format.h"
#include "common/files.h"
#include "common/hash.h"

namespace drape::recognition {

namespace fs = std::filesystem;

void CalibrateOptions::Validate() const {
  if (!(c > 0)) throw Error("calibrate options: c must be > 0 (got " + FormatNumber(c) + ")");
  if (!(epsilon > 0)) throw Error("calibrate options: epsilon must be > 0");
  if (max_iterations < 1) throw Error("calibrate options: max_iterations must be >= 1");
}

namespace {

using Sparse = std::vector<std::pair<unsigned long, double>>;
using SparseKernel = dlib::sparse_linear_kernel<Sparse>;

// One calibration query against the database entries of its category.
struct QueryPairs {
  std::vector<int> relevant, nonrelevant;    // database indices
  std::vector<std::vector<double>> rel_x, non_x;  // dense x̂_i ⊕ q
};

double Dot(const std::vector<double>& w, const std::vector<double>& x) {
  double s = 0;
  for (size_t b = 0; b < x.size(); ++b) {
    if (x[b] != 0) s += w[b];
  }
  return s;
}

// Fraction of (relevant, nonrelevant) pairs with the relevant entry strictly closer.
void PairAccuracy(const std::vector<QueryPairs>& qs, const std::vector<double>& w, long long* good,
                  long long* total, int* top1) {
  *good = 0;
  *total = 0;
  *top1 = 0;
  for (const auto& q : qs) {
    std::vector<double> dr, dn;
    for (const auto& x : q.rel_x) dr.push_back(Dot(w, x));
    for (const auto& x : q.non_x) dn.push_back(Dot(w, x));
    for (double a : dr) {
      for (double b : dn) *good += a < b;
    }
    *total += static_cast<long long>(dr.size()) * dn.size();
    // NN with ties broken by database index, as the recognizer does.
    double best = 1e300;
    int best_idx = 1 << 30;
    bool best_rel = false;
    for (size_t i = 0; i < dr.size(); ++i) {
      if (dr[i] < best || (dr[i] == best && q.relevant[i] < best_idx)) {
        best = dr[i], best_idx = q.relevant[i], best_rel = true;
      }
    }
    for (size_t i = 0; i < dn.size(); ++i) {
      if (dn[i] < best || (dn[i] == best && q.nonrelevant[i] < best_idx)) {
        best = dn[i], best_idx = q.nonrelevant[i], best_rel = false;
      }
    }
    *top1 += best_rel;
  }
}

Sparse NegatedSparse(const std::vector<double>& x) {
  Sparse s;
  for (size_t b = 0; b < x.size(); ++b) {
    if (x[b] != 0) s.emplace_back(b, -x[b]);
  }
  return s;
}

// A calibration query's database entries of its category, relevant (same anchor) or not,
// with their XOR vectors in `frame`.
QueryPairs PairsOf(const Database& db, const LabelledCode& lq, const std::string& cat, WeightFrame frame,
                   std::vector<Match>& matches) {
  PreparedQuery pq(lq.code);
  db.matcher().MatchAll(pq, &matches);
  QueryPairs p;
  for (int i : db.EntriesOf(cat)) {
    // A query ranks only other garment instances: a train entry used as a query would
    // otherwise find itself at distance 0 and teach nothing about other instances.
    if (db.label(i).instance == lq.label.instance) continue;
    std::vector<double> x;
    db.matcher().XorVector(i, pq, matches[i].rotation, frame, &x);
    if (db.label(i).anchor == lq.label.anchor) {
      p.relevant.push_back(i);
      p.rel_x.push_back(std::move(x));
    } else {
      p.nonrelevant.push_back(i);
      p.non_x.push_back(std::move(x));
    }
  }
  return p;
}

// dlib's RankSVM learns f(x) = w·x with f(relevant) > f(nonrelevant). We want the
// relevant entries at the SMALLER weighted distance w·(x̂ ⊕ q), so we hand it the
// negated vectors −(x̂ ⊕ q): w·(−a) > w·(−b) ⇔ w·a < w·b, which is Eq. learn's
// constraint. Non-negative w keeps w·(x̂ ⊕ q) a distance (and is the paper's
// "weighted Hamming distance").
dlib::ranking_pair<Sparse> RankingPair(const QueryPairs& p) {
  dlib::ranking_pair<Sparse> rp;
  for (const auto& x : p.rel_x) rp.relevant.push_back(NegatedSparse(x));
  for (const auto& x : p.non_x) rp.nonrelevant.push_back(NegatedSparse(x));
  // An all-zero XOR (identical features) is an empty sparse vector, which dlib accepts.
  return rp;
}

// The RankSVM's weights (bits of them); *map its mean average precision on the samples.
std::vector<double> TrainWeights(const std::vector<dlib::ranking_pair<Sparse>>& samples,
                                 const CalibrateOptions& options, int bits, double* map) {
  dlib::svm_rank_trainer<SparseKernel> trainer;
  trainer.set_c(options.c);
  trainer.set_epsilon(options.epsilon);
  trainer.set_max_iterations(options.max_iterations);
  trainer.set_learns_nonnegative_weights(options.nonnegative);
  const auto df = trainer.train(samples);
  std::vector<double> w(bits, 0.0);
  for (const auto& [idx, val] : df.basis_vectors(0)) {
    DRAPE_CHECK(idx < static_cast<unsigned long>(bits), "weight index");
    w[idx] = val;
  }
  if (options.nonnegative) {
    for (double& v : w) v = std::max(v, 0.0);  // OCA returns tiny negatives at the bound
  }
  const dlib::matrix<double, 1, 2> acc = dlib::test_ranking_function(df, samples);
  *map = acc(1);
  return w;
}

// One category's weights from its calibration queries (into out.weights) and its
// statistics (into out.categories); queries without both kinds of entries are skipped.
void CalibrateCategory(const Database& db, const std::string& cat, const std::vector<const LabelledCode*>& qs,
                       const CalibrateOptions& options, CalibrationResult& out) {
  const auto t0 = std::chrono::steady_clock::now();
  const int bits = db.layers() * db.rings() * db.sectors();
  CategoryCalibration st;
  st.category = cat;
  std::vector<QueryPairs> pairs;
  std::vector<dlib::ranking_pair<Sparse>> samples;
  std::vector<Match> matches;
  for (const LabelledCode* lq : qs) {
    QueryPairs p = PairsOf(db, *lq, cat, options.frame, matches);
    if (p.relevant.empty() || p.nonrelevant.empty()) {
      ++st.skipped;
      out.warnings.push_back(
          "calibration query " + lq->label.id + " (" + cat + ", anchor '" + lq->label.anchor +
          "'): " + (p.relevant.empty() ? "no database entry has this anchor" : "every database entry has this anchor") +
          "; skipped");
      continue;
    }
    samples.push_back(RankingPair(p));
    st.pairs += static_cast<long long>(p.relevant.size()) * p.nonrelevant.size();
    pairs.push_back(std::move(p));
    ++st.queries;
  }
  if (samples.empty()) {
    out.warnings.push_back("category '" + cat + "': no usable calibration query; it stays unweighted");
    out.categories.push_back(st);
    return;
  }
  std::vector<double> w = TrainWeights(samples, options, bits, &st.map_after);

  long long good = 0, total = 0;
  PairAccuracy(pairs, std::vector<double>(bits, 1.0), &good, &total, &st.top1_before);
  st.accuracy_before = total ? double(good) / total : 0;
  PairAccuracy(pairs, w, &good, &total, &st.top1_after);
  st.accuracy_after = total ? double(good) / total : 0;
  st.nonzero_fraction = double(std::count_if(w.begin(), w.end(), [](double v) { return v > 1e-9; })) / bits;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.weights.per_category[cat] = std::move(w);
  out.categories.push_back(st);
}

// Right category and right anchor of one selection query for every candidate gate.
void ScoreGates(const Database& db, const Code& code, const EntryLabel& ql, const std::vector<double>& taus,
                std::vector<Match>& matches, GateSelection& g) {
  PreparedQuery pq(code);
  db.matcher().MatchAll(pq, &matches);
  std::vector<int> others, same_category;
  for (int i = 0; i < db.size(); ++i) {
    if (db.label(i).instance == ql.instance) continue;
    others.push_back(i);
    if (db.label(i).category == ql.category) same_category.push_back(i);
  }
  if (others.empty()) return;
  auto nearest = [&](const std::vector<int>& pool) { return NearestUnweighted(pool, matches); };
  for (size_t k = 0; k < taus.size(); ++k) {
    g.category_right[k] += db.label(nearest(HeightGated(db, others, ql.height, taus[k]))).category == ql.category;
    if (!same_category.empty()) {
      g.pose_right[k] += db.label(nearest(HeightGated(db, same_category, ql.height, taus[k]))).anchor == ql.anchor;
    }
  }
}

// The weakest τ within one standard error of the best (the "one-standard-error rule" of
// model selection, Breiman et al. 1984; Hastie et al., ESL §7.10): with ~100 selection
// queries the right-answer counts of neighbouring gates differ by noise, and a weaker
// gate discards less of the feature's information. SE = sqrt(p(1 − p)/n) of the best rate p.
double BestGate(const std::vector<double>& taus, const std::vector<int>& right, int queries) {
  const int best = *std::max_element(right.begin(), right.end());
  const double p = double(best) / queries;
  const double slack = std::sqrt(p * (1 - p) / queries) * queries;
  for (size_t k = 0; k < taus.size(); ++k) {
    if (right[k] >= best - slack) return taus[k];
  }
  return taus.front();
}

}  // namespace

GateSelection SelectHeightGates(const Database& db, const std::vector<LabelledCode>& queries,
                                const CalibrateOptions& options) {
  GateSelection g;
  // Weakest first, so that ties keep the weaker gate; 0 = no gate.
  g.taus = {0, 0.5, 0.4, 0.3, 0.25, 0.2, 0.15, 0.12, 0.1, 0.08, 0.06, 0.05, 0.04, 0.03, 0.02};
  g.category_right.assign(g.taus.size(), 0);
  g.pose_right.assign(g.taus.size(), 0);
  std::vector<Match> matches;
  std::set<std::string> seen;  // a train split given as calibration queries counts once
  auto add = [&](const Code& code, const EntryLabel& l) {
    if (!seen.insert(l.id).second) return;
    if (l.height <= 0) {
      ++g.without_height;
      return;
    }
    ++g.queries;
    ScoreGates(db, code, l, g.taus, matches, g);
  };
  for (const auto& q : queries) add(q.code, q.label);
  if (options.gate_train_queries) {
    for (int i = 0; i < db.size(); ++i) add(db.code(i), db.label(i));
  }
  if (g.queries > 0) {
    g.chosen = {BestGate(g.taus, g.category_right, g.queries), BestGate(g.taus, g.pose_right, g.queries)};
  }
  return g;
}

Json ToJson(const GateSelection& g) {
  return Json{{"taus", g.taus},
              {"category_right", g.category_right},
              {"pose_right", g.pose_right},
              {"queries", g.queries},
              {"queries_without_height", g.without_height},
              {"chosen", {{"category", g.chosen.category}, {"pose", g.chosen.pose}}},
              {"rule",
               "per gate: right category / right anchor (category known) of the unweighted nearest neighbour "
               "among the database entries of other garment instances; the weakest gate within one standard "
               "error of the most right answers"}};
}

CalibrationResult Calibrate(const Database& db, const std::vector<LabelledCode>& queries,
                            const CalibrateOptions& options, const std::string& release_digest) {
  options.Validate();
  if (db.empty()) throw Error("calibrate: the database is empty (the release has no usable train entries)");
  if (queries.empty()) throw Error("calibrate: there are no calibration queries");
  CalibrationResult out;
  out.weights.release_digest = release_digest;
  out.weights.layers = db.layers();
  out.weights.rings = db.rings();
  out.weights.sectors = db.sectors();
  out.weights.frame = options.frame;
  out.weights.options = Json{{"c", options.c},
                             {"epsilon", options.epsilon},
                             {"max_iterations", options.max_iterations},
                             {"nonnegative", options.nonnegative},
                             {"solver", "dlib::svm_rank_trainer (OCA cutting plane), C scaled by 1/#pairs"},
                             {"frame", WeightFrameName(options.frame)}};

  std::map<std::string, std::vector<const LabelledCode*>> by_cat;
  for (const auto& q : queries) by_cat[q.label.category].push_back(&q);
  for (const auto& [cat, qs] : by_cat) {
    if (!db.HasCategory(cat)) {
      out.warnings.push_back("category '" + cat + "': " + std::to_string(qs.size()) +
                             " calibration queries but no database entries; skipped");
      continue;
    }
    CalibrateCategory(db, cat, qs, options, out);
  }
  if (options.height_gates) {
    out.gates = SelectHeightGates(db, queries, options);
    out.weights.height_gates = out.gates.chosen;
    if (out.gates.queries == 0) out.warnings.push_back("no query has a known height: no height gates");
  }
  out.weights.options["height_gates"] = options.height_gates;
  out.weights.options["gate_train_queries"] = options.gate_train_queries;
  Json cats = Json::array();
  for (const auto& c : out.categories) cats.push_back(ToJson(c));
  out.weights.stats = Json{{"categories", cats}, {"warnings", out.warnings}};
  if (options.height_gates) out.weights.stats["height_gates"] = ToJson(out.gates);
  return out;
}

Json ToJson(const CategoryCalibration& c) {
  return Json{{"category", c.category},
              {"queries", c.queries},
              {"skipped", c.skipped},
              {"pairs", c.pairs},
              {"ranking_accuracy_unweighted", c.accuracy_before},
              {"ranking_accuracy_learned", c.accuracy_after},
              {"mean_average_precision_learned", c.map_after},
              {"top1_unweighted", c.top1_before},
              {"top1_learned", c.top1_after},
              {"nonzero_weight_fraction", c.nonzero_fraction},
              {"seconds", c.seconds}};
}

void SaveWeights(const Weights& w, const fs::path& dir) {
  std::string bin;
  Json cats = Json::object();
  for (const auto& [cat, v] : w.per_category) {
    std::string bytes(v.size() * sizeof(double), '\0');
    static_assert(std::endian::native == std::endian::little, "weights.bin is little-endian float64");
    std::memcpy(bytes.data(), v.data(), bytes.size());
    cats[cat] = Json{{"offset", bin.size()}, {"count", v.size()}, {"sha256", Sha256Hex(bytes)}};
    bin += bytes;
  }
  Json j{{"format", "drape-recognition-weights"},
         {"version", 1},
         {"release_digest", w.release_digest},
         {"feature", {{"layers", w.layers}, {"rings", w.rings}, {"sectors", w.sectors}}},
         {"frame", WeightFrameName(w.frame)},
         {"bin", "weights.bin"},
         {"bin_sha256", Sha256Hex(bin)},
         {"categories", cats},
         {"height_gates", {{"category", w.height_gates.category}, {"pose", w.height_gates.pose}}},
         {"options", w.options},
         {"stats", w.stats}};
  WriteFileAtomic(dir / "weights.bin", bin);
  WriteFileAtomic(dir / "weights.json", j.dump(2) + "\n");
}

Weights LoadWeights(const fs::path& path, const std::string& expected_digest) {
  const fs::path json_path = fs::is_directory(path) ? path / "weights.json" : path;
  if (!fs::exists(json_path)) throw Error(json_path.string() + ": no weights file (run `drape calibrate` first)");
  Json j;
  try {
    j = Json::parse(ReadFile(json_path));
  } catch (const Json::exception& e) {
    throw Error(json_path.string() + ": not valid JSON: " + e.what());
  }
  try {
    if (j.value("format", "") != "drape-recognition-weights") {
      throw Error(json_path.string() + ": not a drape weights file (format field)");
    }
    Weights w;
    w.release_digest = j.at("release_digest").get<std::string>();
    if (!expected_digest.empty() && w.release_digest != expected_digest) {
      throw Error(json_path.string() + ": these weights were learned on release digest " + w.release_digest +
                  ", but the release has digest " + expected_digest +
                  "; recalibrate with `drape calibrate` on this release");
    }
    w.layers = j.at("feature").at("layers").get<int>();
    w.rings = j.at("feature").at("rings").get<int>();
    w.sectors = j.at("feature").at("sectors").get<int>();
    w.frame = ParseWeightFrame(j.value("frame", "query"));
    const int bits = w.layers * w.rings * w.sectors;
    const fs::path bin_path = json_path.parent_path() / j.at("bin").get<std::string>();
    const std::string bin = ReadFile(bin_path);
    if (Sha256Hex(bin) != j.at("bin_sha256").get<std::string>()) {
      throw Error(bin_path.string() + ": SHA-256 differs from weights.json (corrupt or replaced)");
    }
    for (const auto& [cat, info] : j.at("categories").items()) {
      const size_t off = info.at("offset").get<size_t>();
      const size_t count = info.at("count").get<size_t>();
      if (static_cast<int>(count) != bits || off + count * sizeof(double) > bin.size()) {
        throw Error(json_path.string() + ": category '" + cat + "' weights do not fit the feature shape or weights.bin");
      }
      std::vector<double> v(count);
      std::memcpy(v.data(), bin.data() + off, count * sizeof(double));
      w.per_category[cat] = std::move(v);
    }
    w.options = j.value("options", Json::object());
    w.stats = j.value("stats", Json::object());
    if (j.contains("height_gates")) {  // absent in weights from before the gates: none
      w.height_gates.category = j["height_gates"].at("category").get<double>();
      w.height_gates.pose = j["height_gates"].at("pose").get<double>();
      if (!(w.height_gates.category >= 0 && w.height_gates.pose >= 0)) {
        throw Error(json_path.string() + ": height_gates must be >= 0");
      }
    }
    return w;
  } catch (const Json::exception& e) {
    throw Error(json_path.string() + ": malformed weights file: " + e.what());
  }
}

}  // namespace drape::recognition
