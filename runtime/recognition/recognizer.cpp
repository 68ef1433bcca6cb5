#include "runtime/recognition/recognizer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "common/error.h"
#include "common/timing.h"

namespace drape::recognition {

namespace {
std::string JoinNames(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s.empty() ? "none" : s;
}
}  // namespace

Database::Database(std::vector<LabelledCode> entries, Kernel kernel) {
  if (entries.empty()) return;
  const Code& first = entries.front().code;
  first.Check("database entry " + entries.front().label.id);
  matcher_ = Matcher(first.layers, first.rings, first.sectors, kernel);
  labels_.reserve(entries.size());
  codes_.reserve(entries.size());
  for (auto& e : entries) {
    matcher_.Add(e.code, "database entry " + e.label.id);
    by_category_[e.label.category].push_back(static_cast<int>(labels_.size()));
    labels_.push_back(std::move(e.label));
    codes_.push_back(std::move(e.code));
  }
}

std::vector<std::string> Database::categories() const {
  std::vector<std::string> out;
  for (const auto& [c, v] : by_category_) out.push_back(c);
  return out;
}

std::vector<std::string> Database::instances(const std::string& category) const {
  std::set<std::string> s;
  auto it = by_category_.find(category);
  if (it != by_category_.end()) {
    for (int i : it->second) s.insert(labels_[i].instance);
  }
  return {s.begin(), s.end()};
}

const std::vector<int>& Database::EntriesOf(const std::string& category) const {
  static const std::vector<int> kEmpty;
  auto it = by_category_.find(category);
  return it == by_category_.end() ? kEmpty : it->second;
}

void RecognizeOptions::Validate() const {
  if (top_k < 1) throw Error("recognize options: top_k must be >= 1 (got " + std::to_string(top_k) + ")");
  if (top_entries < 0)
    throw Error("recognize options: top_entries must be >= 0 (got " + std::to_string(top_entries) + ")");
  if (!(query_height >= 0)) throw Error("recognize options: query_height must be >= 0 m (0 = unknown)");
  if (gates && !(gates->category >= 0 && gates->pose >= 0)) {
    throw Error("recognize options: height gates must be >= 0 (0 = no gate)");
  }
}

bool PassesHeightGate(double query_h, double entry_h, double tau) {
  if (tau <= 0 || query_h <= 0 || entry_h <= 0) return true;
  return std::abs(std::log(query_h / entry_h)) <= tau;
}

std::vector<int> HeightGated(const Database& db, const std::vector<int>& pool, double query_h, double tau) {
  if (tau <= 0 || query_h <= 0 || pool.empty()) return pool;
  // Widened to the nearest entry's ratio + τ when none is within τ (an outlier query
  // then still compares with the entries of the nearest heights, not with all).
  double nearest = std::numeric_limits<double>::infinity();
  for (int i : pool) {
    const double h = db.label(i).height;
    nearest = std::min(nearest, h > 0 ? std::abs(std::log(query_h / h)) : 0.0);
  }
  const double bound = nearest <= tau ? tau : nearest + tau;
  std::vector<int> kept;
  for (int i : pool) {
    if (PassesHeightGate(query_h, db.label(i).height, bound)) kept.push_back(i);
  }
  return kept;
}

int NearestUnweighted(const std::vector<int>& pool, const std::vector<Match>& matches) {
  int best = pool.front();
  for (int i : pool) {
    if (matches[i].distance < matches[best].distance) best = i;
  }
  return best;
}

Recognizer::Recognizer(const Database& db, const Weights* weights) : db_(db) {
  if (!weights) return;
  if (!db.empty() &&
      (weights->layers != db.layers() || weights->rings != db.rings() || weights->sectors != db.sectors())) {
    std::ostringstream os;
    os << "weights are for features of shape " << weights->layers << "x" << weights->rings << "x" << weights->sectors
       << ", the database has " << db.layers() << "x" << db.rings() << "x" << db.sectors();
    throw Error(os.str());
  }
  for (const auto& [cat, w] : weights->per_category) {
    if (static_cast<int>(w.size()) != weights->layers * weights->rings * weights->sectors) {
      throw Error("weights for category '" + cat + "' have " + std::to_string(w.size()) + " values, expected " +
                  std::to_string(weights->layers * weights->rings * weights->sectors));
    }
    weights_.emplace(cat, PreparedWeights(w, weights->layers, weights->rings, weights->sectors, weights->frame));
  }
  gates_ = weights->height_gates;
}

HeightGates Recognizer::GatesFor(const RecognizeOptions& options) const {
  if (options.query_height <= 0 || !options.height_gates) return {};
  return options.gates ? *options.gates : gates_;
}

Recognition Recognizer::Recognize(const Code& query, const RecognizeOptions& options) const {
  options.Validate();
  if (db_.empty()) throw Error("recognize: the database is empty (the release has no usable train entries)");
  const auto t0 = Clock::now();
  PreparedQuery q(query);
  std::vector<Match> matches;
  db_.matcher().MatchAll(q, &matches);
  Recognition r = Rank(q, matches, options);
  r.match_seconds = Since(t0);
  return r;
}

namespace {
// `entries` scored (weighted by `w` if given, else Eq. match's distance) and sorted, best
// first (ties: the lower entry).
std::vector<Candidate> Ranked(const Database& db, const std::vector<int>& entries, const PreparedQuery& q,
                              const std::vector<Match>& matches, const PreparedWeights* w) {
  std::vector<Candidate> cands;
  cands.reserve(entries.size());
  for (int i : entries) {
    Candidate c;
    c.entry = i;
    const EntryLabel& l = db.label(i);
    c.id = l.id;
    c.category = l.category;
    c.instance = l.instance;
    c.anchor = l.anchor;
    c.distance = matches[i].distance;
    c.rotation = matches[i].rotation;
    c.score = w ? db.matcher().Weighted(i, q, c.rotation, *w) : double(c.distance);
    cands.push_back(std::move(c));
  }
  std::stable_sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
    if (a.score != b.score) return a.score < b.score;
    return a.entry < b.entry;
  });
  return cands;
}
}  // namespace

Recognition Recognizer::Rank(const PreparedQuery& q, const std::vector<Match>& matches,
                             const RecognizeOptions& options) const {
  options.Validate();
  if (db_.empty()) throw Error("recognize: the database is empty (the release has no usable train entries)");
  DRAPE_CHECK(static_cast<int>(matches.size()) == db_.size(), "one match per database entry");
  Recognition r;
  r.compared = db_.size();

  // 1. Category: given, or that of the unweighted nearest neighbour (ties: lowest index)
  //    among the entries that pass the category height gate.
  r.query_height = options.query_height;
  r.gates = GatesFor(options);
  if (!options.category.empty()) {
    if (!db_.HasCategory(options.category)) {
      throw Error("recognize: category '" + options.category +
                  "' is not in the database (it has: " + JoinNames(db_.categories()) + ")");
    }
    r.category = options.category;
    r.category_source = "given";
  } else {
    std::vector<int> all(db_.size());
    for (int i = 0; i < db_.size(); ++i) all[i] = i;
    const std::vector<int> pool = HeightGated(db_, all, options.query_height, r.gates.category);
    r.category = db_.label(NearestUnweighted(pool, matches)).category;
    r.category_source = "unweighted_nn";
    r.category_pool = static_cast<int>(pool.size());
  }

  // 2. Pose inside the category (height-gated), under its learned w if there is one.
  std::vector<int> pool;
  for (int i : db_.EntriesOf(r.category)) {
    const std::string& inst = db_.label(i).instance;
    if (options.instances.empty() ||
        std::find(options.instances.begin(), options.instances.end(), inst) != options.instances.end()) {
      pool.push_back(i);
    }
  }
  if (pool.empty()) {
    throw Error("recognize: database instance '" + JoinNames(options.instances) + "' has no entries of category '" +
                r.category + "' (instances: " + JoinNames(db_.instances(r.category)) + ")");
  }
  const std::vector<int> ungated = pool;
  pool = HeightGated(db_, pool, options.query_height, r.gates.pose);
  r.pose_pool = static_cast<int>(pool.size());
  const PreparedWeights* w = nullptr;
  if (options.weighted) {
    auto it = weights_.find(r.category);
    if (it != weights_.end()) w = &it->second;
  }
  r.weighted = w != nullptr;
  const std::vector<Candidate> cands = Ranked(db_, pool, q, matches, w);
  r.best = cands.front();
  r.anchor = r.best.anchor;
  if (options.top_entries > 0) {
    std::vector<Candidate> all = Ranked(db_, ungated, q, matches, w);
    if (static_cast<int>(all.size()) > options.top_entries) all.resize(options.top_entries);
    r.entries = std::move(all);
  }
  std::set<std::string> seen;
  for (const auto& c : cands) {
    if (static_cast<int>(r.top.size()) >= options.top_k) break;
    if (seen.insert(c.anchor).second) r.top.push_back(c);
  }
  return r;
}

Json ToJson(const Recognition& r) {
  auto cand = [](const Candidate& c) {
    return Json{{"entry", c.id},          {"category", c.category}, {"instance", c.instance}, {"anchor", c.anchor},
                {"distance", c.distance}, {"rotation", c.rotation}, {"score", c.score}};
  };
  Json top = Json::array();
  for (const auto& c : r.top) top.push_back(cand(c));
  Json out{{"category", r.category},
           {"category_source", r.category_source},
           {"anchor", r.anchor},
           {"weighted", r.weighted},
           {"best", cand(r.best)},
           {"top", top},
           {"compared", r.compared},
           {"query_height", r.query_height},
           {"height_gates", {{"category", r.gates.category}, {"pose", r.gates.pose}}},
           {"category_pool", r.category_pool},
           {"pose_pool", r.pose_pool}};
  if (!r.entries.empty()) {  // only when asked for (RecognizeOptions::top_entries)
    Json entries = Json::array();
    for (const auto& c : r.entries) entries.push_back(cand(c));
    out["entries"] = std::move(entries);
  }
  return out;
}

}  // namespace drape::recognition
