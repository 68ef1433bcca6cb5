// The category by registration (see category_fit.h).
#include "runtime/recognition/category_fit.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <numbers>
#include <set>

#include "common/closest_point.h"
#include "common/error.h"
#include "common/field_error.h"
#include "common/parallel.h"
#include "common/timing.h"
#include "garments/io.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/release_source.h"
#include "runtime/recognition/selection.h"
#include "runtime/registration/registration.h"

namespace drape::recognition {

void CategoryFitOptions::Validate() const {
  if (per_category < 1) BadField(per_category, "per_category", "must be >= 1, got " + std::to_string(per_category));
  if (top_categories < 0)
    BadField(top_categories, "top_categories", "must be >= 0 (0 = all), got " + std::to_string(top_categories));
  if (!(bits_weight >= 0) || !std::isfinite(bits_weight))
    BadField(bits_weight, "bits_weight", "must be a finite number >= 0");
}

std::vector<int> CategoryPool(const Database& db, double query_height, double tau,
                              const std::string& exclude_instance) {
  std::vector<int> all;
  for (int i = 0; i < db.size(); ++i) {
    if (exclude_instance.empty() || db.label(i).instance != exclude_instance) all.push_back(i);
  }
  return HeightGated(db, all, query_height, tau);
}

std::vector<FitCandidate> ChooseFitCandidates(const Database& db, const std::vector<int>& pool,
                                              const std::vector<Match>& matches, const CategoryFitOptions& options) {
  options.Validate();
  if (pool.empty()) throw Error("category fit: no database entry to choose from");
  std::map<std::string, std::vector<int>> by_category;
  for (int i : pool) by_category[db.label(i).category].push_back(i);
  std::vector<std::pair<int, std::string>> nearest;  // (best distance, category)
  for (auto& [cat, v] : by_category) {
    std::stable_sort(v.begin(), v.end(), [&](int a, int b) {
      return matches[a].distance != matches[b].distance ? matches[a].distance < matches[b].distance : a < b;
    });
    nearest.emplace_back(matches[v.front()].distance, cat);
  }
  std::sort(nearest.begin(), nearest.end());
  if (options.top_categories > 0 && static_cast<int>(nearest.size()) > options.top_categories)
    nearest.resize(options.top_categories);
  std::set<std::string> kept;
  for (const auto& [d, cat] : nearest) kept.insert(cat);
  std::vector<FitCandidate> out;
  for (const auto& [cat, v] : by_category) {
    if (!kept.count(cat)) continue;
    for (int k = 0; k < std::min<int>(options.per_category, static_cast<int>(v.size())); ++k) {
      FitCandidate c;
      c.entry = v[k];
      c.id = db.label(v[k]).id;
      c.category = cat;
      c.distance = matches[v[k]].distance;
      c.rotation = matches[v[k]].rotation;
      out.push_back(std::move(c));
    }
  }
  return out;
}

std::string DecideByFit(const std::vector<FitCandidate>& candidates, const CategoryFitOptions& options,
                        std::map<std::string, double>* scores) {
  options.Validate();
  // Per category: its best distance (first candidate) and the least fit of its first k.
  struct PerCategory {
    int distance = -1, seen = 0;
    double fit = -1;
  };
  std::map<std::string, PerCategory> cats;
  for (const FitCandidate& c : candidates) {
    PerCategory& p = cats[c.category];
    if (p.seen++ == 0) p.distance = c.distance;
    if (p.seen > options.per_category || !(c.fit >= 0) || !std::isfinite(c.fit)) continue;
    if (p.fit < 0 || c.fit < p.fit) p.fit = c.fit;
  }
  std::vector<std::pair<int, std::string>> nearest;
  nearest.reserve(cats.size());
  for (const auto& [cat, p] : cats) nearest.emplace_back(p.distance, cat);
  std::sort(nearest.begin(), nearest.end());
  if (options.top_categories > 0 && static_cast<int>(nearest.size()) > options.top_categories)
    nearest.resize(options.top_categories);
  double min_fit = -1;
  int min_d = -1;
  for (const auto& [d, cat] : nearest) {
    const double f = cats[cat].fit;
    if (f < 0) continue;
    if (min_fit < 0 || f < min_fit) min_fit = f;
    if (min_d < 0 || d < min_d) min_d = d;
  }
  if (scores) scores->clear();
  if (min_fit < 0) return "";
  std::string best;
  double best_score = 0;
  int best_d = 0;
  for (const auto& [d, cat] : nearest) {  // by distance, then name: ties keep the earlier
    const double f = cats[cat].fit;
    if (f < 0) continue;
    const double s = f / std::max(min_fit, 1e-9) + options.bits_weight * d / std::max(min_d, 1);
    if (scores) (*scores)[cat] = s;
    if (best.empty() || s < best_score || (s == best_score && d < best_d)) best = cat, best_score = s, best_d = d;
  }
  return best;
}

TriMesh TurnedToQuery(const TriMesh& mesh, int rotation, int sectors) {
  TriMesh out = mesh;
  if (sectors <= 0) return out;
  const double yaw = 2 * std::numbers::pi * rotation / sectors;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Vec3::UnitY()).toRotationMatrix();
  for (int j = 0; j < out.NumVertices(); ++j) out.V.row(j) = (R * out.V.row(j).transpose()).transpose();
  return out;
}

void RegisterFitCandidates(std::vector<FitCandidate>& candidates, const TriMesh& recon, int sectors,
                           const std::function<TriMesh(int)>& hung_mesh, const CategoryFitOptions& options) {
  options.Validate();
  registration::RegistrationOptions ro;
  ro.nonrigid = false;
  ro.scale = options.scale;
  ro.grid.threads = 1;
  const ExactClosestPoint onto_recon(recon);
  ParallelFor(static_cast<int>(candidates.size()), options.threads, [&](int i) {
    FitCandidate& c = candidates[i];
    const auto t0 = Clock::now();
    try {
      const TriMesh source = TurnedToQuery(hung_mesh(c.entry), c.rotation, sectors);
      const registration::RegistrationResult r = registration::Register(source, recon, ro);
      c.fit = registration::SymmetricFit(r.rigid, recon, onto_recon);
      if (!std::isfinite(c.fit)) c.fit = -1, c.failure = "registration gave a non-finite fit";
    } catch (const Error& e) {
      c.fit = -1;
      c.failure = e.what();
    }
    c.seconds = Since(t0);
  });
}

CategoryFit DecideCategoryByFit(const Database& db, const std::vector<int>& pool, const std::vector<Match>& matches,
                                const TriMesh& recon, const std::function<TriMesh(int)>& hung_mesh,
                                const CategoryFitOptions& options) {
  const auto t0 = Clock::now();
  CategoryFit out;
  out.candidates = ChooseFitCandidates(db, pool, matches, options);
  RegisterFitCandidates(out.candidates, recon, db.sectors(), hung_mesh, options);
  out.category = DecideByFit(out.candidates, options, &out.scores);
  out.seconds = Since(t0);
  return out;
}

Json ToJson(const CategoryFit& fit) {
  Json cands = Json::array();
  for (const FitCandidate& c : fit.candidates) {
    Json j{{"entry", c.id}, {"category", c.category}, {"distance", c.distance}, {"rotation", c.rotation}};
    j["fit"] = c.fit >= 0 ? Json(c.fit) : Json(nullptr);
    if (!c.failure.empty()) j["failure"] = c.failure;
    cands.push_back(std::move(j));
  }
  Json scores = Json::object();
  for (const auto& [c, s] : fit.scores) scores[c] = s;
  return Json{{"category", fit.category}, {"candidates", cands}, {"scores", scores}, {"seconds", fit.seconds}};
}

std::function<TriMesh(int)> ReleaseHungMeshes(const Release& release, const Database& db) {
  struct Cache {
    std::mutex mu;
    std::map<int, TriMesh> meshes;
  };
  auto cache = std::make_shared<Cache>();
  return [cache, &release, &db](int entry) {
    {
      std::lock_guard<std::mutex> lock(cache->mu);
      auto it = cache->meshes.find(entry);
      if (it != cache->meshes.end()) return it->second;
    }
    TriMesh m = ReadMesh(release.EntryPath(db.label(entry).id, "hang.ply"));
    std::lock_guard<std::mutex> lock(cache->mu);
    return cache->meshes.emplace(entry, std::move(m)).first->second;
  };
}

CategoryFit RecognitionCategoryByFit(const Database& db, const Recognizer& rec, const RecognizeOptions& o,
                                     const std::vector<Match>& matches, const TriMesh& recon,
                                     const std::function<TriMesh(int)>& hung_mesh, const CategoryFitOptions& options) {
  const std::vector<int> pool = CategoryPool(db, o.query_height, rec.GatesFor(o).category);
  return DecideCategoryByFit(db, pool, matches, recon, hung_mesh, options);
}

CategoryFit EntryCategoryByFit(const Release& release, const Database& db, const Recognizer& rec, const Code& q,
                               const RecognizeOptions& o, const std::string& entry, const CategoryFitOptions& options) {
  if (!o.category.empty()) throw Error("category by registration: the category is given ('" + o.category + "')");
  const std::filesystem::path recon_path = release.EntryPath(entry, "recon.ply");
  if (!std::filesystem::exists(recon_path))
    throw Error("category by registration: entry " + entry + " has no reconstruction (" + recon_path.string() + ")");
  std::vector<Match> matches;
  db.matcher().MatchAll(PreparedQuery(q), &matches);
  return RecognitionCategoryByFit(db, rec, o, matches, ReadMesh(recon_path), ReleaseHungMeshes(release, db), options);
}

namespace {

// One query of the evaluation or the selection: its category by the unweighted nearest
// neighbour and by registration.
struct FitQuery {
  const LabelledCode* query = nullptr;
  std::string exclude_instance;  // a database entry queried against the others
  std::string nearest;           // the unweighted nearest neighbour's category
  CategoryFit fit;
  std::vector<Match> matches;
  std::string failure;  // the query itself could not be registered (no recon.ply)
};

void RunFitQuery(const Release& release, const Database& db, double tau, const std::function<TriMesh(int)>& hung,
                 const CategoryFitOptions& options, FitQuery& q) {
  const EntryLabel& l = q.query->label;
  db.matcher().MatchAll(PreparedQuery(q.query->code), &q.matches);
  const std::vector<int> pool = CategoryPool(db, l.height, tau, q.exclude_instance);
  if (pool.empty()) {
    q.failure = "no database entry of another instance";
    return;
  }
  q.nearest = db.label(NearestUnweighted(pool, q.matches)).category;
  try {
    const auto t0 = Clock::now();
    const TriMesh recon = ReadMesh(release.EntryPath(l.id, "recon.ply"));
    CategoryFitOptions one = options;
    one.threads = 1;  // parallel over queries instead
    q.fit = DecideCategoryByFit(db, pool, q.matches, recon, hung, one);
    q.fit.seconds = Since(t0);
  } catch (const Error& e) {
    q.failure = e.what();
  }
}

struct Rate {
  int n = 0, right = 0;
  void Add(bool ok) { ++n, right += ok; }
  Json Value() const { return n ? Json(double(right) / n) : Json(nullptr); }
};

struct FitAcc {
  Rate nearest, fit, e2e_nn_u, e2e_nn_l, e2e_fit_u, e2e_fit_l;
  double seconds = 0;
  Json ToJson(const std::string& name) const {
    return Json{{"category", name},
                {"queries", nearest.n},
                {"category_accuracy", {{"unweighted_nn", nearest.Value()}, {"registration", fit.Value()}}},
                {"end_to_end_pose_accuracy",
                 {{"unweighted_nn", {{"unweighted", e2e_nn_u.Value()}, {"learned", e2e_nn_l.Value()}}},
                  {"registration", {{"unweighted", e2e_fit_u.Value()}, {"learned", e2e_fit_l.Value()}}}}},
                {"seconds_per_query", nearest.n ? Json(seconds / nearest.n) : Json(nullptr)}};
  }
};

// End to end with category `category` given: right category and right anchor.
bool EndToEnd(const Recognizer& rec, const FitQuery& q, const std::string& category, bool weighted) {
  const EntryLabel& l = q.query->label;
  if (category != l.category) return false;
  RecognizeOptions o;
  o.category = category;
  o.weighted = weighted;
  o.query_height = l.height;
  return rec.Rank(PreparedQuery(q.query->code), q.matches, o).anchor == l.anchor;
}

Json OptionsToJson(const CategoryFitOptions& o) {
  return Json{{"per_category", o.per_category},
              {"top_categories", o.top_categories},
              {"bits_weight", o.bits_weight},
              {"scale", o.scale},
              {"registration", "rigid only (scale + ICP), hang.ply turned by the matched rotation onto recon.ply"},
              {"fit", "SymmetricFit: symmetric mean surface distance, m"}};
}

}  // namespace

Json EvaluateCategoryFit(const Release& release, const Database& db, const Weights* weights,
                         const std::vector<EvalQuery>& queries, const CategoryFitOptions& options) {
  options.Validate();
  const auto t0 = Clock::now();
  const Recognizer rec(db, weights);
  const double tau = weights ? weights->height_gates.category : 0;
  const auto hung = ReleaseHungMeshes(release, db);
  std::vector<FitQuery> qs(queries.size());
  for (size_t i = 0; i < queries.size(); ++i) qs[i].query = &queries[i].query;
  ParallelFor(static_cast<int>(qs.size()), options.threads,
              [&](int i) { RunFitQuery(release, db, tau, hung, options, qs[i]); });
  std::map<std::string, FitAcc> acc;
  FitAcc all;
  Json per_query = Json::array();
  for (const FitQuery& q : qs) {
    const EntryLabel& l = q.query->label;
    // A query that could not be registered keeps the nearest neighbour's category.
    const std::string by_fit = q.fit.category.empty() ? q.nearest : q.fit.category;
    for (FitAcc* a : {&acc[l.category], &all}) {
      a->nearest.Add(q.nearest == l.category);
      a->fit.Add(by_fit == l.category);
      a->e2e_nn_u.Add(EndToEnd(rec, q, q.nearest, false));
      a->e2e_fit_u.Add(EndToEnd(rec, q, by_fit, false));
      if (weights) a->e2e_nn_l.Add(EndToEnd(rec, q, q.nearest, true)), a->e2e_fit_l.Add(EndToEnd(rec, q, by_fit, true));
      a->seconds += q.fit.seconds;
    }
    Json j{{"id", l.id}, {"category", l.category}, {"unweighted_nn", q.nearest}, {"registration", ToJson(q.fit)}};
    if (!q.failure.empty()) j["failure"] = q.failure;
    per_query.push_back(std::move(j));
  }
  Json cats = Json::array();
  for (const auto& [name, a] : acc) cats.push_back(a.ToJson(name));
  cats.push_back(all.ToJson("all"));
  return Json{{"options", OptionsToJson(options)},
              {"category_gate", tau},
              {"categories", cats},
              {"per_query", per_query},
              {"wall_seconds", Since(t0)},
              {"threads", options.threads <= 0 ? HardwareThreads() : options.threads}};
}

namespace {

// The selection grid, cheapest first (fewer registrations, then the fit alone): the
// one-standard-error rule picks the first setting within one SE of the most right.
std::vector<CategoryFitOptions> SelectionGrid() {
  std::vector<CategoryFitOptions> grid;
  for (int k : {1, 2, 3}) {
    for (int top : {2, 0}) {
      for (double lambda : {0.0, 0.25, 0.5, 1.0, 2.0}) {
        CategoryFitOptions o;
        o.per_category = k, o.top_categories = top, o.bits_weight = lambda;
        grid.push_back(o);
      }
    }
  }
  return grid;
}

// One counted selection query's answers: right with grid setting g (the nearest
// neighbour's category where registration decided none).
std::vector<char> GridAnswers(const FitQuery& q, const std::vector<CategoryFitOptions>& grid) {
  std::vector<char> ok(grid.size(), 0);
  for (size_t g = 0; g < grid.size(); ++g) {
    const std::string c = DecideByFit(q.fit.candidates, grid[g]);
    ok[g] = (c.empty() ? q.nearest : c) == q.query->label.category;
  }
  return ok;
}

// The nested leave-one-out of the selection rule over `ok` (selection.h), and how often
// each grid setting was the one chosen on the other queries.
Json NestedJson(const std::vector<std::vector<char>>& ok, const SelectionRule& rule, size_t settings) {
  std::vector<int> chosen;
  const int right = NestedLeaveOneOut(ok, rule, &chosen);
  std::vector<int> times(settings, 0);
  for (int k : chosen) {
    if (k >= 0) ++times[k];
  }
  return Json{{"right", right},
              {"times_chosen", times},
              {"what",
               "each query answered by the setting the rule chooses on the other queries: what the selection "
               "itself is worth, beside the nearest neighbour's count"}};
}

}  // namespace

Json SelectCategoryFit(const Release& release, const Database& db, double category_gate,
                       const std::vector<LabelledCode>& calibration, int threads) {
  const auto t0 = Clock::now();
  std::vector<LabelledCode> train(db.size());
  for (int i = 0; i < db.size(); ++i) train[i] = {db.label(i), db.code(i)};
  std::vector<FitQuery> qs;
  for (const LabelledCode& c : calibration) qs.emplace_back().query = &c;
  int left_out = 0;
  for (const LabelledCode& c : train) {
    if (db.instances(c.label.category).size() < 2) {
      ++left_out;  // no other instance of its category: cannot be right
      continue;
    }
    FitQuery& q = qs.emplace_back();
    q.query = &c;
    q.exclude_instance = c.label.instance;  // queried against the other instances
  }
  CategoryFitOptions largest;
  largest.per_category = 3;
  const auto hung = ReleaseHungMeshes(release, db);
  ParallelFor(static_cast<int>(qs.size()), threads,
              [&](int i) { RunFitQuery(release, db, category_gate, hung, largest, qs[i]); });
  const std::vector<CategoryFitOptions> grid = SelectionGrid();
  std::vector<int> right(grid.size(), 0);
  std::vector<std::map<std::string, int>> by_cat(grid.size());
  int nn_right = 0, n = 0;
  std::map<std::string, int> nn_by_cat, n_by_cat;
  std::vector<std::vector<char>> ok;  // ok[i][g]: counted query i right with grid setting g
  Json per_query = Json::array();
  for (const FitQuery& q : qs) {
    const std::string& truth = q.query->label.category;
    if (!q.failure.empty() && q.nearest.empty()) continue;
    ++n, ++n_by_cat[truth];
    nn_right += q.nearest == truth, nn_by_cat[truth] += q.nearest == truth;
    ok.push_back(GridAnswers(q, grid));
    for (size_t g = 0; g < grid.size(); ++g) right[g] += ok.back()[g], by_cat[g][truth] += ok.back()[g];
    Json j{
        {"id", q.query->label.id}, {"category", truth}, {"unweighted_nn", q.nearest}, {"registration", ToJson(q.fit)}};
    if (!q.exclude_instance.empty()) j["against_other_instances_than"] = q.exclude_instance;
    per_query.push_back(std::move(j));
  }
  Json rows = Json::array();
  for (size_t g = 0; g < grid.size(); ++g)
    rows.push_back({{"options", OptionsToJson(grid[g])}, {"right", right[g]}, {"right_by_category", by_cat[g]}});
  const SelectionRule rule = [&](const std::vector<int>& r, int queries) {
    return OneStandardError(r, std::vector<bool>(r.size(), true), queries);
  };
  const int chosen = rule(right, n);
  return Json{{"queries", n},
              {"chosen", chosen >= 0 ? OptionsToJson(grid[chosen]) : Json(nullptr)},
              {"chosen_right", chosen >= 0 ? Json(right[chosen]) : Json(nullptr)},
              {"rule",
               "the first setting (fewest registrations, then the fit alone) within one standard error of "
               "the most right answers; compare with the unweighted nearest neighbour's count"},
              {"queries_by_category", n_by_cat},
              {"left_out", left_out},
              {"category_gate", category_gate},
              {"nearest_neighbour", {{"right", nn_right}, {"right_by_category", nn_by_cat}}},
              {"nested_leave_one_out", NestedJson(ok, rule, grid.size())},
              {"grid", rows},
              {"per_query", per_query},
              {"wall_seconds", Since(t0)},
              {"threads", threads <= 0 ? HardwareThreads() : threads}};
}

}  // namespace drape::recognition
