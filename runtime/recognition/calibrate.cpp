#include "runtime/recognition/calibrate.h"

#include <dlib/svm.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "common/error.h"
#include "common/files.h"
#include "common/format.h"
#include "common/hash.h"
#include "common/timing.h"

namespace drape::recognition {

namespace fs = std::filesystem;

void CalibrateOptions::Validate() const {
  if (!(c > 0 || (c == 0 && regularizer == Regularizer::kUniform))) {
    throw Error("calibrate options: c must be > 0, or 0 with the uniform prior (w = 1) (got " + FormatNumber(c) + ")");
  }
  if (!(epsilon > 0)) throw Error("calibrate options: epsilon must be > 0");
  if (max_iterations < 1) throw Error("calibrate options: max_iterations must be >= 1");
}

const char* RegularizerName(Regularizer r) { return r == Regularizer::kZero ? "zero" : "uniform"; }

Regularizer ParseRegularizer(const std::string& name) {
  if (name == "zero") return Regularizer::kZero;
  if (name == "uniform") return Regularizer::kUniform;
  throw Error("unknown regularizer '" + name + "' (zero | uniform)");
}

const char* WeightTyingName(WeightTying t) {
  switch (t) {
    case WeightTying::kBit:
      return "bit";
    case WeightTying::kAnnulus:
      return "annulus";
    case WeightTying::kLayer:
      return "layer";
  }
  return "?";
}

WeightTying ParseWeightTying(const std::string& name) {
  if (name == "bit") return WeightTying::kBit;
  if (name == "annulus") return WeightTying::kAnnulus;
  if (name == "layer") return WeightTying::kLayer;
  throw Error("unknown weight tying '" + name + "' (bit | annulus | layer)");
}

std::string CvSetting::Name() const {
  if (c == 0) return "unweighted";
  return std::string(regularizer == Regularizer::kZero ? "plain" : "uniform-prior") + " " + WeightTyingName(tying) +
         " C=" + FormatNumber(c);
}

namespace {

using Sparse = std::vector<std::pair<unsigned long, double>>;
using SparseKernel = dlib::sparse_linear_kernel<Sparse>;

// Feature shape, for the weight groups.
struct Shape {
  int layers = 0, rings = 0, sectors = 0;
  int bits() const { return layers * rings * sectors; }
  int Groups(WeightTying t) const {
    return t == WeightTying::kBit ? bits() : t == WeightTying::kAnnulus ? layers * rings : layers;
  }
  // Bit b = (l·R + r)·Φ + s (Code::Index).
  int GroupOf(int b, WeightTying t) const {
    return t == WeightTying::kBit ? b : t == WeightTying::kAnnulus ? b / sectors : b / (rings * sectors);
  }
};

// One query against the database entries of its category of OTHER garment instances (a
// train entry used as a query would otherwise find itself at distance 0 and teach
// nothing about other instances), with their XOR vectors x̂_i ⊕ q (0/1) at the Eq. match
// rotation in the weights' frame.
struct QueryData {
  const LabelledCode* lq = nullptr;
  std::vector<int> entries;            // database indices, ascending
  std::vector<std::vector<double>> x;  // dense 0/1, one per entry
};

QueryData Gather(const Database& db, const LabelledCode& lq, const std::string& cat, WeightFrame frame,
                 std::vector<Match>& matches) {
  PreparedQuery pq(lq.code);
  db.matcher().MatchAll(pq, &matches);
  QueryData d;
  d.lq = &lq;
  for (int i : db.EntriesOf(cat)) {
    if (db.label(i).instance == lq.label.instance) continue;
    std::vector<double> x;
    db.matcher().XorVector(i, pq, matches[i].rotation, frame, &x);
    d.entries.push_back(i);
    d.x.push_back(std::move(x));
  }
  return d;
}

// The entries of d (positions) that are relevant (the query's anchor) or not, leaving
// out those of garment instance `skip` ("" = none).
void SplitEntries(const Database& db, const QueryData& d, const std::string& skip, std::vector<int>* rel,
                  std::vector<int>* non) {
  rel->clear();
  non->clear();
  for (size_t k = 0; k < d.entries.size(); ++k) {
    const EntryLabel& l = db.label(d.entries[k]);
    if (!skip.empty() && l.instance == skip) continue;
    (l.anchor == d.lq->label.anchor ? rel : non)->push_back(static_cast<int>(k));
  }
}

double Dot(const std::vector<double>& w, const std::vector<double>& x) {
  double s = 0;
  for (size_t b = 0; b < x.size(); ++b) {
    if (x[b] != 0) s += w[b] * x[b];
  }
  return s;
}

// Position (in d) of the nearest of `pool` (positions) under w; ties: lowest database
// index, as the recognizer breaks them.
int Nearest(const QueryData& d, const std::vector<int>& pool, const std::vector<double>& w) {
  double best = 1e300;
  int best_k = -1;
  for (int k : pool) {
    const double v = Dot(w, d.x[k]);
    if (v < best || (v == best && d.entries[k] < d.entries[best_k])) best = v, best_k = k;
  }
  return best_k;
}

// Fraction of (relevant, nonrelevant) pairs with the relevant entry strictly closer, and
// the queries whose nearest entry is relevant.
void PairAccuracy(const Database& db, const std::vector<QueryData>& qs, const std::vector<double>& w, long long* good,
                  long long* total, int* top1) {
  *good = 0;
  *total = 0;
  *top1 = 0;
  std::vector<int> rel, non;
  for (const auto& d : qs) {
    SplitEntries(db, d, "", &rel, &non);
    if (rel.empty() || non.empty()) continue;
    for (int a : rel) {
      const double da = Dot(w, d.x[a]);
      for (int b : non) *good += da < Dot(w, d.x[b]);
    }
    *total += static_cast<long long>(rel.size()) * non.size();
    std::vector<int> all(d.entries.size());
    for (size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
    *top1 += db.label(d.entries[Nearest(d, all, w)]).anchor == d.lq->label.anchor;
  }
}

// −(x̂ ⊕ q) summed over each weight group. dlib's RankSVM learns f(z) = v·z with
// f(relevant) > f(nonrelevant); we want the relevant entries at the SMALLER weighted
// distance v·(x̂ ⊕ q), so we hand it the negated sums: v·(−a) > v·(−b) ⇔ v·a < v·b,
// which is Eq. learn's constraint. An all-zero XOR is an empty vector, which dlib accepts.
Sparse TiedNegated(const std::vector<double>& x, WeightTying t, const Shape& sh) {
  Sparse s;
  for (size_t b = 0; b < x.size(); ++b) {
    if (x[b] == 0) continue;
    const unsigned long g = sh.GroupOf(static_cast<int>(b), t);
    if (!s.empty() && s.back().first == g) {
      s.back().second -= x[b];
    } else {
      s.emplace_back(g, -x[b]);
    }
  }
  return s;
}

// Per query, per entry: the tied negated vectors for one tying (computed once, shared by
// the folds and values of C).
using TiedCache = std::vector<std::vector<Sparse>>;
TiedCache Tie(const std::vector<QueryData>& qs, WeightTying t, const Shape& sh) {
  TiedCache c(qs.size());
  for (size_t q = 0; q < qs.size(); ++q) {
    for (const auto& x : qs[q].x) c[q].push_back(TiedNegated(x, t, sh));
  }
  return c;
}

// The ranking problems of the queries not of instance `skip`, against the entries not of
// instance `skip`; *pairs their relevant × nonrelevant count, *used / *unusable queries.
std::vector<dlib::ranking_pair<Sparse>> Samples(const Database& db, const std::vector<QueryData>& qs,
                                                const TiedCache& tied, const std::string& skip, long long* pairs,
                                                std::vector<bool>* used) {
  std::vector<dlib::ranking_pair<Sparse>> samples;
  std::vector<int> rel, non;
  *pairs = 0;
  used->assign(qs.size(), false);
  for (size_t q = 0; q < qs.size(); ++q) {
    if (!skip.empty() && qs[q].lq->label.instance == skip) continue;
    SplitEntries(db, qs[q], skip, &rel, &non);
    if (rel.empty() || non.empty()) continue;
    dlib::ranking_pair<Sparse> rp;
    for (int k : rel) rp.relevant.push_back(tied[q][k]);
    for (int k : non) rp.nonrelevant.push_back(tied[q][k]);
    samples.push_back(std::move(rp));
    *pairs += static_cast<long long>(rel.size()) * non.size();
    (*used)[q] = true;
  }
  return samples;
}

// The RankSVM's per-bit weights (group weights copied to their bits); *map its mean
// average precision on the samples, *clipped the bits set from < 0 to 0.
std::vector<double> TrainWeights(const std::vector<dlib::ranking_pair<Sparse>>& samples,
                                 const CalibrateOptions& options, const Shape& sh, double* map, int* clipped) {
  const int groups = sh.Groups(options.tying);
  std::vector<double> v(groups, 1.0);
  *clipped = 0;
  *map = 0;
  if (options.c > 0) {
    dlib::svm_rank_trainer<SparseKernel> trainer;
    trainer.set_c(options.c);
    trainer.set_epsilon(options.epsilon);
    trainer.set_max_iterations(options.max_iterations);
    if (options.regularizer == Regularizer::kUniform) {
      // ½‖v − 1‖²: dlib's prior; the unweighted distance is v = 1.
      dlib::decision_function<SparseKernel> prior;
      Sparse ones;
      for (int g = 0; g < groups; ++g) ones.emplace_back(g, 1.0);
      prior.alpha.set_size(1);
      prior.alpha(0) = 1;
      prior.basis_vectors.set_size(1);
      prior.basis_vectors(0) = ones;
      prior.b = 0;
      trainer.set_prior(prior);
    } else {
      trainer.set_learns_nonnegative_weights(options.nonnegative);
    }
    const auto df = trainer.train(samples);
    std::fill(v.begin(), v.end(), 0.0);
    for (const auto& [idx, val] : df.basis_vectors(0)) {
      DRAPE_CHECK(idx < static_cast<unsigned long>(groups), "weight index");
      v[idx] = val;
    }
    const dlib::matrix<double, 1, 2> acc = dlib::test_ranking_function(df, samples);
    *map = acc(1);
  }
  std::vector<double> w(sh.bits());
  for (int b = 0; b < sh.bits(); ++b) {
    double x = v[sh.GroupOf(b, options.tying)];
    if (x < 0) {
      // kZero: OCA returns tiny negatives at the w ≥ 0 bound. kUniform: dlib cannot keep
      // w ≥ 0 with a prior; a negative weight would reward a differing bit, so it is 0.
      if (options.regularizer == Regularizer::kUniform && x < -1e-9) ++*clipped;
      x = 0;
    }
    w[b] = x;
  }
  return w;
}

// The queries of one category, gathered once.
std::vector<QueryData> GatherCategory(const Database& db, const std::string& cat,
                                      const std::vector<const LabelledCode*>& qs, WeightFrame frame) {
  std::vector<QueryData> out;
  std::vector<Match> matches;
  out.reserve(qs.size());
  for (const LabelledCode* lq : qs) out.push_back(Gather(db, *lq, cat, frame, matches));
  return out;
}

// One category's weights from its calibration queries (into out.weights) and its
// statistics (into out.categories); queries without both kinds of entries are skipped.
void CalibrateCategory(const Database& db, const std::string& cat, const std::vector<const LabelledCode*>& qs,
                       const CalibrateOptions& options, CalibrationResult& out) {
  const auto t0 = Clock::now();
  const Shape sh{db.layers(), db.rings(), db.sectors()};
  CategoryCalibration st;
  st.category = cat;
  const std::vector<QueryData> data = GatherCategory(db, cat, qs, options.frame);
  const TiedCache tied = Tie(data, options.tying, sh);
  std::vector<bool> used;
  const auto samples = Samples(db, data, tied, "", &st.pairs, &used);
  std::vector<QueryData> usable;
  std::vector<int> rel, non;
  std::map<std::string, int> alone;  // instance → its queries with no other instance to rank
  for (size_t q = 0; q < data.size(); ++q) {
    if (used[q]) {
      usable.push_back(data[q]);
      ++st.queries;
      continue;
    }
    ++st.skipped;
    if (data[q].entries.empty()) {
      ++alone[data[q].lq->label.instance];
      continue;
    }
    SplitEntries(db, data[q], "", &rel, &non);
    const LabelledCode* lq = data[q].lq;
    out.warnings.push_back(
        "calibration query " + lq->label.id + " (" + cat + ", anchor '" + lq->label.anchor + "'): " +
        (rel.empty() ? "no database entry has this anchor" : "every database entry has this anchor") + "; skipped");
  }
  for (const auto& [inst, n] : alone) {
    out.warnings.push_back(std::to_string(n) + " " + cat + " queries of garment instance '" + inst +
                           "': the database has no entry of another instance of this category to rank; skipped");
  }
  if (samples.empty()) {
    out.warnings.push_back("category '" + cat + "': no usable calibration query; it stays unweighted");
    out.categories.push_back(st);
    return;
  }
  std::vector<double> w = TrainWeights(samples, options, sh, &st.map_after, &st.clipped);

  long long good = 0, total = 0;
  PairAccuracy(db, usable, std::vector<double>(sh.bits(), 1.0), &good, &total, &st.top1_before);
  st.accuracy_before = total ? double(good) / total : 0;
  PairAccuracy(db, usable, w, &good, &total, &st.top1_after);
  st.accuracy_after = total ? double(good) / total : 0;
  st.nonzero_fraction = double(std::count_if(w.begin(), w.end(), [](double v) { return v > 1e-9; })) / sh.bits();
  double dep = 0;
  for (double v : w) dep += std::abs(v - 1);
  st.mean_abs_departure = dep / sh.bits();
  st.seconds = Since(t0);
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
  const int k = OneStandardError(right, std::vector<bool>(right.size(), true), queries);
  return k >= 0 ? taus[k] : taus.front();
}

}  // namespace

HeightGates ChooseHeightGates(const std::vector<double>& taus, const std::vector<int>& category_right,
                              const std::vector<int>& pose_right, int queries) {
  if (queries <= 0 || taus.empty()) return {};
  // Ties keep the first, the weakest (calibrate.h says why the category's rule is not the pose's).
  const int c = MostRight(category_right);
  return {c >= 0 ? taus[c] : taus.front(), BestGate(taus, pose_right, queries)};
}

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
    g.chosen = ChooseHeightGates(g.taus, g.category_right, g.pose_right, g.queries);
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
               "among the database entries of other garment instances; category: the weakest gate with the most "
               "right answers; pose: the weakest gate within one standard error of the most right answers"}};
}

std::vector<CvSetting> DefaultCvGrid() {
  std::vector<CvSetting> g;
  auto add = [&g](Regularizer r, WeightTying t, double c, bool eligible) {
    CvSetting s;
    s.regularizer = r;
    s.tying = t;
    s.c = c;
    s.eligible = eligible;
    g.push_back(s);
  };
  add(Regularizer::kUniform, WeightTying::kLayer, 0, true);  // unweighted
  for (WeightTying t : {WeightTying::kLayer, WeightTying::kAnnulus, WeightTying::kBit}) {
    for (double c : {0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 100.0}) add(Regularizer::kUniform, t, c, true);
  }
  add(Regularizer::kZero, WeightTying::kBit, 10, false);  // the paper's, reported only
  return g;
}

CrossValidation CrossValidate(const Database& db, const std::vector<LabelledCode>& queries,
                              const CalibrateOptions& base, const HeightGates& gates, std::vector<CvSetting> settings) {
  base.Validate();
  CrossValidation cv;
  cv.settings = std::move(settings);
  const Shape sh{db.layers(), db.rings(), db.sectors()};
  std::map<std::string, std::vector<const LabelledCode*>> by_cat;
  std::set<std::string> seen;  // a query given twice counts once
  for (const auto& q : queries) {
    if (seen.insert(q.label.id).second) by_cat[q.label.category].push_back(&q);
  }
  for (const auto& [cat, qs] : by_cat) {
    if (!db.HasCategory(cat)) continue;
    const std::vector<QueryData> data = GatherCategory(db, cat, qs, base.frame);
    std::map<WeightTying, TiedCache> tied;
    std::set<std::string> instances;
    for (const auto& d : data) instances.insert(d.lq->label.instance);
    for (const std::string& h : instances) {
      // The held-out queries and, for each, the positions of its gated pool (all its
      // entries are of other instances than h already).
      std::vector<int> held;
      std::vector<std::vector<int>> pools;
      for (size_t q = 0; q < data.size(); ++q) {
        const QueryData& d = data[q];
        if (d.lq->label.instance != h || d.entries.empty()) continue;
        const std::vector<int> gated = HeightGated(db, d.entries, d.lq->label.height, gates.pose);
        std::vector<int> pos;
        for (size_t k = 0; k < d.entries.size(); ++k) {
          if (std::binary_search(gated.begin(), gated.end(), d.entries[k])) pos.push_back(static_cast<int>(k));
        }
        held.push_back(static_cast<int>(q));
        pools.push_back(std::move(pos));
      }
      if (held.empty()) continue;
      ++cv.folds;
      cv.queries += static_cast<int>(held.size());
      cv.queries_by_category[cat] += static_cast<int>(held.size());
      for (CvSetting& s : cv.settings) {
        std::vector<double> w(sh.bits(), 1.0);
        if (s.c > 0) {
          if (!tied.count(s.tying)) tied[s.tying] = Tie(data, s.tying, sh);
          long long pairs = 0;
          std::vector<bool> used;
          const auto samples = Samples(db, data, tied[s.tying], h, &pairs, &used);
          if (!samples.empty()) {  // else the category stays unweighted, as Calibrate leaves it
            CalibrateOptions o = base;
            o.c = s.c;
            o.regularizer = s.regularizer;
            o.tying = s.tying;
            double map = 0;
            int clipped = 0;
            w = TrainWeights(samples, o, sh, &map, &clipped);
          }
        }
        for (size_t j = 0; j < held.size(); ++j) {
          const QueryData& d = data[held[j]];
          const int k = Nearest(d, pools[j], w);
          const int right = k >= 0 && db.label(d.entries[k]).anchor == d.lq->label.anchor;
          s.right += right;
          s.right_by_category[cat] += right;
        }
      }
    }
  }
  std::vector<int> right;
  std::vector<bool> eligible;
  for (const auto& s : cv.settings) right.push_back(s.right), eligible.push_back(s.eligible);
  cv.chosen = OneStandardError(right, eligible, cv.queries);
  return cv;
}

Json ToJson(const CrossValidation& cv) {
  Json settings = Json::array();
  for (const auto& s : cv.settings) {
    settings.push_back(Json{{"setting", s.Name()},
                            {"regularizer", RegularizerName(s.regularizer)},
                            {"tying", WeightTyingName(s.tying)},
                            {"c", s.c},
                            {"eligible", s.eligible},
                            {"right", s.right},
                            {"right_by_category", s.right_by_category}});
  }
  return Json{{"settings", settings},
              {"queries", cv.queries},
              {"queries_by_category", cv.queries_by_category},
              {"folds", cv.folds},
              {"chosen", cv.chosen >= 0 ? Json(cv.settings[cv.chosen].Name()) : Json()},
              {"rule",
               "leave one garment instance out per category (its queries held out, its database entries in "
               "no training pair); a held-out query is ranked, category known, against the entries of the "
               "other instances through the pose height gate; the simplest eligible setting within one "
               "standard error of the most right answers"}};
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
                             {"regularizer", RegularizerName(options.regularizer)},
                             {"tying", WeightTyingName(options.tying)},
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
              {"negative_weights_clipped", c.clipped},
              {"mean_abs_departure_from_1", c.mean_abs_departure},
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
        throw Error(json_path.string() + ": category '" + cat +
                    "' weights do not fit the feature shape or weights.bin");
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
