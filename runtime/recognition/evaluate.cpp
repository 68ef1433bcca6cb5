#include "runtime/recognition/evaluate.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "common/error.h"
#include "common/proportion.h"

namespace drape::recognition {

std::vector<std::string> AnchorTokens(const std::string& label) {
  std::vector<std::string> tokens(1);
  for (char c : label) {
    if (c == '_') {
      tokens.emplace_back();
    } else {
      tokens.back() += c;
    }
  }
  return tokens;
}

std::vector<std::string> SymmetryTwins(const std::string& anchor) {
  // Whole '_'-separated tokens only, so e.g. "leftover" stays as it is.
  const std::vector<std::string> tokens = AnchorTokens(anchor);
  auto swapped = [&](bool lr, bool tb) {
    std::string out;
    for (size_t i = 0; i < tokens.size(); ++i) {
      std::string t = tokens[i];
      if (lr && (t == "left" || t == "right")) t = t == "left" ? "right" : "left";
      if (tb && (t == "top" || t == "bottom")) t = t == "top" ? "bottom" : "top";
      out += (i ? "_" : "") + t;
    }
    return out;
  };
  std::vector<std::string> out;
  for (const auto& [lr, tb] : {std::pair{true, false}, {false, true}, {true, true}}) {
    const std::string t = swapped(lr, tb);
    if (t != anchor && std::find(out.begin(), out.end(), t) == out.end()) out.push_back(t);
  }
  return out;
}

void EvalOptions::Validate() const {
  if (top_k < 1) throw Error("eval options: top_k must be >= 1");
}

namespace {

// The database subsets of the pose table: each instance alone ("instance1" … "instanceN",
// N the most instances a category has, at least 2 as the paper's table), the first two
// together ("instances1_2", the paper's database of two models per type; only when some
// category has more than 2) and all of the category's instances ("both": the paper's name
// and the key readers know; the markdown calls it "all" when it is more than two).
std::vector<std::string> Subsets(const Database& db) {
  size_t most = 2;
  for (const std::string& c : db.categories()) most = std::max(most, db.instances(c).size());
  std::vector<std::string> out;
  for (size_t i = 1; i <= most; ++i) out.push_back("instance" + std::to_string(i));
  if (most > 2) out.push_back("instances1_2");
  out.push_back("both");
  return out;
}

// Restricts `o` to `subset` of the category's sorted instances; false when the category
// has no such instance (n/a, as the paper's shorts' instance 2).
bool RestrictToSubset(const std::string& subset, const std::vector<std::string>& insts, RecognizeOptions& o) {
  if (subset == "both") return true;
  if (subset == "instances1_2") {
    o.instances.assign(insts.begin(), insts.begin() + std::min<size_t>(2, insts.size()));
    return true;
  }
  const size_t k = std::stoul(subset.substr(std::string("instance").size()));
  if (k < 1 || k > insts.size()) return false;
  o.instances = {insts[k - 1]};
  return true;
}

const char* kMetrics[] = {"unweighted", "learned"};

// The paper's Table (real Kinect data), by our category names.
Json PaperRow(const std::string& category) {
  if (category == "long_sleeve_shirt" || category == "shirt") {
    return Json{{"garment", "Long-Sleeve Shirts"},
                {"instance1", 0.631},
                {"instance2", 0.684},
                {"both", 0.737},
                {"seconds", 0.30}};
  }
  if (category == "pants") {
    return Json{{"garment", "Pants"}, {"instance1", 0.75}, {"instance2", 0.75}, {"both", 0.75}, {"seconds", 0.20}};
  }
  if (category == "shorts") {
    return Json{
        {"garment", "Shorts"}, {"instance1", 0.625}, {"instance2", nullptr}, {"both", 0.625}, {"seconds", 0.22}};
  }
  return nullptr;
}

double GraspErrorCm(const AnchorUvMap& uvs, const std::string& query_instance, const std::string& db_instance,
                    const std::string& truth, const std::string& predicted) {
  if (truth == predicted) return 0.0;
  for (const std::string& inst : {query_instance, db_instance}) {
    auto a = uvs.find({inst, truth});
    auto b = uvs.find({inst, predicted});
    if (a != uvs.end() && b != uvs.end()) return 100.0 * (a->second - b->second).norm();
  }
  return std::nan("");
}

struct Counter {
  int n = 0, correct = 0;
  void Add(bool ok) { ++n, correct += ok; }
  Json Rate() const { return n ? Json(double(correct) / n) : Json(nullptr); }
};

struct Mean {
  double sum = 0;
  int n = 0, unknown = 0;
  void Add(double v) {
    if (std::isnan(v) || v < 0) {
      ++unknown;
    } else {
      sum += v, ++n;
    }
  }
  Json Value() const { return n ? Json(sum / n) : Json(nullptr); }
};

struct CategoryAcc {
  int queries = 0;
  int absent = 0;                       // queries whose category is not in the database
  std::map<std::string, Counter> pose;  // "subset/metric"
  Counter category, top_u, top_l, e2e_u, e2e_l;
  Counter twin_u, twin_l;  // both instances, the anchor or its mirror twin
  // The paper's Algorithm 1 alone (no height gates): category, both instances u / l.
  Counter paper_category, paper_u, paper_l;
  Mean grasp_u, grasp_l, fusion, feature, match, total;
  bool learned = false;
  std::vector<std::string> instances;
};

// End-to-end recognition (category by unweighted NN, pose by the learned w), timed: this
// is what one query costs at run time. Leaves the query's matches in `matches`.
Recognition ScoreEndToEnd(const Recognizer& rec, const Database& db, const EvalQuery& eq, const PreparedQuery& pq,
                          bool have_weights, int top_k, std::vector<Match>& matches, CategoryAcc& ca, CategoryAcc& all,
                          Json& rec_json) {
  const EntryLabel& ql = eq.query.label;
  RecognizeOptions e2e;
  e2e.top_k = top_k;
  e2e.query_height = ql.height;
  Recognition r_e2e = rec.Recognize(eq.query.code, e2e);
  e2e.weighted = false;
  db.matcher().MatchAll(pq, &matches);
  const Recognition r_e2e_u = rec.Rank(pq, matches, e2e);
  const bool cat_ok = r_e2e.category == ql.category;
  ca.category.Add(cat_ok), all.category.Add(cat_ok);
  e2e.height_gates = false;
  const bool paper_cat_ok = rec.Rank(pq, matches, e2e).category == ql.category;
  ca.paper_category.Add(paper_cat_ok), all.paper_category.Add(paper_cat_ok);
  rec_json["query_height"] = ql.height;
  ca.e2e_u.Add(cat_ok && r_e2e_u.anchor == ql.anchor), all.e2e_u.Add(cat_ok && r_e2e_u.anchor == ql.anchor);
  if (have_weights) {
    ca.e2e_l.Add(cat_ok && r_e2e.anchor == ql.anchor), all.e2e_l.Add(cat_ok && r_e2e.anchor == ql.anchor);
  }
  rec_json["predicted_category"] = r_e2e.category;
  rec_json["end_to_end"] = {
      {"unweighted", r_e2e_u.anchor}, {"learned", r_e2e.anchor}, {"learned_used_weights", r_e2e.weighted}};
  return r_e2e;
}

// Seconds per query; the total only when the build recorded both fusion and feature times.
void ScoreTiming(const EvalQuery& eq, double match_seconds, CategoryAcc& ca, CategoryAcc& all, Json& rec_json) {
  const double total =
      eq.fusion_seconds >= 0 && eq.feature_seconds >= 0 ? eq.fusion_seconds + eq.feature_seconds + match_seconds : -1;
  for (CategoryAcc* a : {&ca, &all}) {
    a->fusion.Add(eq.fusion_seconds);
    a->feature.Add(eq.feature_seconds);
    a->match.Add(match_seconds);
    a->total.Add(total);
  }
  rec_json["timing"] = {{"fusion_seconds", eq.fusion_seconds >= 0 ? Json(eq.fusion_seconds) : Json(nullptr)},
                        {"feature_seconds", eq.feature_seconds >= 0 ? Json(eq.feature_seconds) : Json(nullptr)},
                        {"match_seconds", match_seconds},
                        {"source", eq.timing_source}};
}

// A query whose category the database lacks: wrong everywhere (unweighted columns only:
// the learned columns cover categories that have weights).
void ScoreAbsentCategory(const std::vector<std::string>& subsets, CategoryAcc& ca, CategoryAcc& all, Json& rec_json) {
  ++ca.absent;
  for (const std::string& s : subsets) {
    ca.pose[s + "/unweighted"].Add(false), all.pose[s + "/unweighted"].Add(false);
  }
  ca.top_u.Add(false), all.top_u.Add(false);
  rec_json["error"] = "category absent from the database";
}

// Category known: the paper's table, per database subset and metric.
Json ScoreKnownCategory(const Recognizer& rec, const Database& db, const AnchorUvMap& uvs, const EntryLabel& ql,
                        const PreparedQuery& pq, const std::vector<Match>& matches,
                        const std::vector<std::string>& subsets, int top_k, CategoryAcc& ca, CategoryAcc& all,
                        EvalResult& out) {
  const std::vector<std::string> insts = db.instances(ql.category);
  ca.instances = insts;
  ca.learned = rec.HasWeights(ql.category);
  Json results = Json::object();
  for (const std::string& s : subsets) {
    for (const char* m : kMetrics) {
      const bool learned = std::string(m) == "learned";
      if (learned && !ca.learned) continue;  // N/A: no weights for this category
      RecognizeOptions o;
      if (!RestrictToSubset(s, insts, o)) break;  // N/A: the category has no such instance
      o.top_k = top_k;
      o.category = ql.category;
      o.weighted = learned;
      o.query_height = ql.height;
      const Recognition r = rec.Rank(pq, matches, o);
      const bool ok = r.anchor == ql.anchor;
      if (s == "both") {
        o.height_gates = false;
        const bool paper_ok = rec.Rank(pq, matches, o).anchor == ql.anchor;
        (learned ? ca.paper_l : ca.paper_u).Add(paper_ok);
        (learned ? all.paper_l : all.paper_u).Add(paper_ok);
      }
      const std::string key = s + "/" + m;
      ca.pose[key].Add(ok), all.pose[key].Add(ok);
      Json rj{{"anchor", r.anchor},          {"entry", r.best.id},    {"distance", r.best.distance},
              {"rotation", r.best.rotation}, {"score", r.best.score}, {"correct", ok}};
      if (s == "both") {
        const std::vector<std::string> twins = SymmetryTwins(ql.anchor);
        const bool twin_ok = ok || std::find(twins.begin(), twins.end(), r.anchor) != twins.end();
        (learned ? ca.twin_l : ca.twin_u).Add(twin_ok);
        (learned ? all.twin_l : all.twin_u).Add(twin_ok);
        rj["twin_credited"] = twin_ok;
        bool in_top = false;
        for (const auto& c : r.top) in_top |= c.anchor == ql.anchor;
        (learned ? ca.top_l : ca.top_u).Add(in_top);
        (learned ? all.top_l : all.top_u).Add(in_top);
        const double ge = GraspErrorCm(uvs, ql.instance, r.best.instance, ql.anchor, r.anchor);
        (learned ? ca.grasp_l : ca.grasp_u).Add(ge);
        (learned ? all.grasp_l : all.grasp_u).Add(ge);
        rj["grasp_error_cm"] = std::isnan(ge) ? Json(nullptr) : Json(ge);
        rj["top"] = Json::array();
        for (const auto& c : r.top) rj["top"].push_back(c.anchor);
        if (learned || !ca.learned) out.confusion[ql.category].metric = learned ? "learned" : "unweighted";
      }
      results[key] = rj;
    }
  }
  return results;
}

// Confusion matrices (both instances; learned if the category has weights).
void FillConfusion(const Database& db, const std::vector<EvalQuery>& queries, const Json& per_query, EvalResult& out) {
  for (auto& [cat, conf] : out.confusion) {
    std::set<std::string> labels;
    for (int i : db.EntriesOf(cat)) labels.insert(db.label(i).anchor);
    for (const auto& q : queries) {
      if (q.query.label.category == cat) labels.insert(q.query.label.anchor);
    }
    conf.labels.assign(labels.begin(), labels.end());
    conf.counts.assign(conf.labels.size(), std::vector<int>(conf.labels.size(), 0));
    // Captures the labels, not the structured binding (clang 14 rejects capturing those).
    const std::vector<std::string>& sorted = conf.labels;
    auto index = [&sorted](const std::string& l) {
      return static_cast<int>(std::lower_bound(sorted.begin(), sorted.end(), l) - sorted.begin());
    };
    const std::string key = "both/" + conf.metric;
    for (const auto& pq : per_query) {
      if (pq["category"] != cat || !pq.contains("category_known") || !pq["category_known"].contains(key)) continue;
      ++conf.counts[index(pq["anchor"].get<std::string>())]
                   [index(pq["category_known"][key]["anchor"].get<std::string>())];
    }
  }
}

Json ProportionJson(const Counter& c) {
  if (c.n == 0) return nullptr;
  const Proportion w = WilsonInterval(c.correct, c.n);
  return Json{{"correct", c.correct}, {"n", c.n}, {"low", w.low}, {"high", w.high}};
}

// How precise the row's headline figures are (common/proportion.h): strict pose (both
// instances, in the distance the tables print: learned where the row has learned
// figures, as StrictTwinCell in report_format.h), twin credited and category accuracy as
// k of n with a 95 % Wilson interval, and the difference another run of the same size
// (another recipe seed) must show in strict pose before it is more than chance, with the
// queries per run a 5-point difference needs.
Json PrecisionRow(const CategoryAcc& a) {
  auto counter = [&](const std::string& key) {
    auto it = a.pose.find(key);
    return it == a.pose.end() ? Counter{} : it->second;
  };
  const Counter u = counter("both/unweighted"), l = counter("both/learned");
  const bool learned = l.n > 0;
  const Counter& strict = learned ? l : u;
  Json row{{"metric", learned ? "learned" : "unweighted"},
           {"strict", ProportionJson(strict)},
           {"twin_credited", ProportionJson(learned ? a.twin_l : a.twin_u)},
           {"category", ProportionJson(a.category)}};
  if (strict.n > 0) {
    const double p = double(strict.correct) / strict.n;
    row["strict_difference_beyond_chance"] = DifferenceBeyondChance(p, strict.n);
    row["strict_queries_for_5_points"] = TrialsForDifference(p, 0.05);
  }
  return row;
}

// One row of report.json "categories" (or "overall").
Json CategoryRow(const std::string& name, const CategoryAcc& a, const std::vector<std::string>& subsets, int top_k) {
  Json pose = Json::object();
  for (const std::string& s : subsets) {
    Json pm = Json::object();
    for (const char* m : kMetrics) {
      auto it = a.pose.find(s + "/" + m);
      pm[m] = it == a.pose.end() ? Json(nullptr) : it->second.Rate();
    }
    pose[s] = pm;
  }
  return Json{{"category", name},
              {"queries", a.queries},
              {"queries_category_absent", a.absent},
              {"database_instances", a.instances},
              {"learned_weights", a.learned},
              {"pose_accuracy", pose},
              {"category_accuracy", a.category.Rate()},
              {"without_height_gates",
               {{"category_accuracy", a.paper_category.Rate()},
                {"pose_accuracy_both", {{"unweighted", a.paper_u.Rate()}, {"learned", a.paper_l.Rate()}}}}},
              {"pose_accuracy_twin_credited", {{"unweighted", a.twin_u.Rate()}, {"learned", a.twin_l.Rate()}}},
              {"end_to_end_pose_accuracy", {{"unweighted", a.e2e_u.Rate()}, {"learned", a.e2e_l.Rate()}}},
              {"top_k_accuracy", {{"k", top_k}, {"unweighted", a.top_u.Rate()}, {"learned", a.top_l.Rate()}}},
              {"grasp_error_cm",
               {{"surface", "flat pattern of the query's garment instance (uv distance)"},
                {"unweighted_mean", a.grasp_u.Value()},
                {"learned_mean", a.grasp_l.Value()},
                {"unknown", a.grasp_u.unknown + a.grasp_l.unknown}}},
              {"seconds_per_query",
               {{"fusion", a.fusion.Value()},
                {"feature", a.feature.Value()},
                {"matching", a.match.Value()},
                {"total", a.total.Value()},
                {"fusion_known", a.fusion.n},
                {"feature_known", a.feature.n}}},
              {"precision", PrecisionRow(a)},
              {"paper", PaperRow(name)}};
}

}  // namespace

EvalResult Evaluate(const Database& db, const Weights* weights, const std::vector<EvalQuery>& queries,
                    const AnchorUvMap& uvs, const EvalOptions& options) {
  options.Validate();
  if (db.empty()) throw Error("eval: the database is empty (the release has no usable train entries)");
  if (queries.empty()) throw Error("eval: the split has no usable queries");
  Recognizer rec(db, weights);
  EvalResult out;
  std::map<std::string, CategoryAcc> acc;
  CategoryAcc all;
  Json per_query = Json::array();
  std::vector<std::string> warnings;
  std::set<std::string> warned_absent;
  std::vector<Match> matches;
  const std::vector<std::string> subsets = Subsets(db);

  for (const EvalQuery& eq : queries) {
    const EntryLabel& ql = eq.query.label;
    CategoryAcc& ca = acc[ql.category];
    ++ca.queries, ++all.queries;
    Json rec_json{{"id", ql.id}, {"category", ql.category}, {"instance", ql.instance}, {"anchor", ql.anchor}};
    const PreparedQuery pq(eq.query.code);
    const Recognition r_e2e =
        ScoreEndToEnd(rec, db, eq, pq, weights != nullptr, options.top_k, matches, ca, all, rec_json);
    ScoreTiming(eq, r_e2e.match_seconds, ca, all, rec_json);
    if (!db.HasCategory(ql.category)) {
      if (warned_absent.insert(ql.category).second)
        warnings.push_back("category '" + ql.category + "' has test queries but no database entries");
      ScoreAbsentCategory(subsets, ca, all, rec_json);
    } else {
      rec_json["category_known"] =
          ScoreKnownCategory(rec, db, uvs, ql, pq, matches, subsets, options.top_k, ca, all, out);
    }
    per_query.push_back(rec_json);
  }
  FillConfusion(db, queries, per_query, out);

  Json cats = Json::array();
  for (const auto& [name, a] : acc) cats.push_back(CategoryRow(name, a, subsets, options.top_k));
  Json conf_json = Json::object();
  for (const auto& [cat, c] : out.confusion) {
    conf_json[cat] = {{"metric", c.metric}, {"labels", c.labels}, {"counts", c.counts}};
  }
  out.report = Json{{"queries", static_cast<int>(queries.size())},
                    {"database",
                     {{"entries", db.size()},
                      {"categories", db.categories()},
                      {"feature", {{"layers", db.layers()}, {"rings", db.rings()}, {"sectors", db.sectors()}}},
                      {"kernel", KernelName(db.matcher().kernel())}}},
                    {"top_k", options.top_k},
                    {"height_gates",
                     weights ? Json{{"category", weights->height_gates.category}, {"pose", weights->height_gates.pose}}
                             : Json{{"category", 0}, {"pose", 0}}},
                    {"categories", cats},
                    {"overall", CategoryRow("all", all, subsets, options.top_k)},
                    {"confusion", conf_json},
                    {"warnings", warnings},
                    {"per_query", per_query}};
  return out;
}

}  // namespace drape::recognition
