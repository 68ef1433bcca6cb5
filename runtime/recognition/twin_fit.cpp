// The twin discriminator by the cue's fit (see twin_fit.h).
#include "runtime/recognition/twin_fit.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "common/closest_point.h"
#include "common/error.h"
#include "common/parallel.h"
#include "common/timing.h"
#include "garments/io.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/category_fit.h"
#include "runtime/recognition/selection.h"
#include "runtime/registration/registration.h"

namespace drape::recognition {

namespace {

bool HasToken(const std::string& label, const std::string& token) {
  const std::vector<std::string> t = AnchorTokens(label);
  return std::find(t.begin(), t.end(), token) != t.end();
}

// The entry of (instance, anchor) in `category`; -1 when none.
int FindEntry(const Database& db, const std::string& category, const std::string& instance, const std::string& anchor) {
  if (!db.HasCategory(category)) return -1;
  for (int e : db.EntriesOf(category)) {
    if (db.label(e).instance == instance && db.label(e).anchor == anchor) return e;
  }
  return -1;
}

bool IsSigned(TwinDirection d) {
  return d == TwinDirection::kDbSigned || d == TwinDirection::kReconSigned || d == TwinDirection::kSigned;
}

// A side's residual for a direction and radius index (m; signed ones may be < 0); none
// when not measurable.
std::optional<double> SideValue(const TwinSide& s, TwinDirection d, size_t r) {
  if (s.whole_fit < 0) return std::nullopt;
  if (d == TwinDirection::kWhole) return s.whole_fit;
  if (r >= s.cue.size()) return std::nullopt;
  const CueResidual& c = s.cue[r];
  const bool db = c.db_samples > 0, recon = c.recon_samples > 0;
  switch (d) {
    case TwinDirection::kDbToRecon:
      return db ? std::optional(c.db_to_recon) : std::nullopt;
    case TwinDirection::kReconToDb:
      return recon ? std::optional(c.recon_to_db) : std::nullopt;
    case TwinDirection::kBoth:
      return db && recon ? std::optional(0.5 * (c.db_to_recon + c.recon_to_db)) : std::nullopt;
    case TwinDirection::kDbSigned:
      return db ? std::optional(c.db_signed) : std::nullopt;
    case TwinDirection::kReconSigned:
      return recon ? std::optional(c.recon_signed) : std::nullopt;
    case TwinDirection::kSigned:
      return db && recon ? std::optional(0.5 * (c.db_signed + c.recon_signed)) : std::nullopt;
    default:
      return std::nullopt;
  }
}

Vec3 FaceNormal(const TriMesh& m, int f) {
  const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
  const Vec3 n = (b - a).cross(c - a);
  const double l = n.norm();
  return l > 0 ? Vec3(n / l) : Vec3::Zero();
}

// Area-weighted mean over the patches of `from` within `radius` of a centre of the
// distance to `to` signed along the reconstruction's outward normal: `recon` is `to`
// (normal at the closest point's face) or, with `from_is_recon`, `from` (the patch's own
// normal, pointing from it to the closest point). > 0: the database mesh lies outside.
double SignedNear(const TriMesh& from, const ExactClosestPoint& to, const TriMesh& recon,
                  const std::vector<Vec3>& centres, double radius, bool from_is_recon) {
  const Eigen::VectorXd area = FaceAreas(from);
  const Points3 g = FaceCentroids(from);
  const double r2 = radius * radius;
  double s = 0, total = 0;
  for (int f = 0; f < from.NumFaces(); ++f) {
    const Vec3 p = g.row(f);
    if (std::none_of(centres.begin(), centres.end(), [&](const Vec3& x) { return (p - x).squaredNorm() <= r2; }))
      continue;
    const ClosestPoint c = to.Query(p);
    if (c.triangle < 0) continue;
    const double d =
        from_is_recon ? (c.point - p).dot(FaceNormal(recon, f)) : (p - c.point).dot(FaceNormal(recon, c.triangle));
    s += area[f] * d;
    total += area[f];
  }
  return total > 0 ? s / total : 0;
}

CueResidual MeasureCueWith(const TriMesh& registered, const ExactClosestPoint& onto_registered,
                           const std::vector<int>& cue, const TriMesh& recon, const ExactClosestPoint& onto_recon,
                           double radius) {
  std::vector<Vec3> centres;
  for (int v : cue) {
    if (v >= 0 && v < registered.NumVertices()) centres.push_back(registered.V.row(v).transpose());
  }
  CueResidual c;
  if (centres.empty()) return c;
  const registration::DirectedDistance a = registration::MeasureDirectedNear(registered, onto_recon, centres, radius);
  const registration::DirectedDistance b = registration::MeasureDirectedNear(recon, onto_registered, centres, radius);
  c.db_samples = a.samples, c.recon_samples = b.samples;
  if (a.samples > 0) c.db_to_recon = a.mean;
  if (b.samples > 0) c.recon_to_db = b.mean;
  c.db_signed = SignedNear(registered, onto_recon, recon, centres, radius, false);
  c.recon_signed = SignedNear(recon, onto_registered, recon, centres, radius, true);
  return c;
}
}  // namespace

const TwinDirection kTwinDirections[] = {TwinDirection::kDbToRecon, TwinDirection::kReconToDb,   TwinDirection::kBoth,
                                         TwinDirection::kDbSigned,  TwinDirection::kReconSigned, TwinDirection::kSigned,
                                         TwinDirection::kWhole};

std::string TwinDirectionName(TwinDirection d) {
  switch (d) {
    case TwinDirection::kDbToRecon:
      return "db";
    case TwinDirection::kReconToDb:
      return "recon";
    case TwinDirection::kBoth:
      return "both";
    case TwinDirection::kDbSigned:
      return "db_signed";
    case TwinDirection::kReconSigned:
      return "recon_signed";
    case TwinDirection::kSigned:
      return "signed";
    case TwinDirection::kWhole:
      return "whole";
  }
  return "?";
}

TwinDirection ParseTwinDirection(const std::string& name) {
  for (TwinDirection d : kTwinDirections) {
    if (TwinDirectionName(d) == name) return d;
  }
  throw Error("twin fit: direction must be db, recon, both, db_signed, recon_signed, signed or whole (got '" + name +
              "')");
}

void TwinFitOptions::Validate() const {
  if (!(radius > 0) || !std::isfinite(radius))
    throw Error("twin fit: radius must be a finite number > 0 (m; got " + std::to_string(radius) + ")");
  if (instances != 0 && instances != 1)
    throw Error("twin fit: instances must be 1 (the matched entry's) or 0 (every instance; got " +
                std::to_string(instances) + ")");
  if (!(margin >= 0 && margin < 1))
    throw Error("twin fit: margin must be in [0, 1) (got " + std::to_string(margin) + ")");
}

std::vector<std::string> CueAnchors(const std::vector<std::string>& anchors) {
  std::vector<std::string> neck, waist;
  for (const std::string& a : anchors) {
    if (HasToken(a, "collar") || HasToken(a, "neck")) neck.push_back(a);
    if (HasToken(a, "waist")) waist.push_back(a);
  }
  return neck.empty() ? waist : neck;
}

std::vector<int> CueVertices(const Database& db, const std::string& instance) {
  std::vector<std::string> anchors;
  std::map<std::string, int> vertex;
  for (int i = 0; i < db.size(); ++i) {
    const EntryLabel& l = db.label(i);
    if (l.instance != instance || l.anchor_vertex < 0) continue;
    anchors.push_back(l.anchor);
    vertex[l.anchor] = l.anchor_vertex;
  }
  std::set<int> out;
  for (const std::string& a : CueAnchors(anchors)) out.insert(vertex[a]);
  return {out.begin(), out.end()};
}

CueResidual MeasureCue(const TriMesh& registered, const std::vector<int>& cue, const TriMesh& recon,
                       const ExactClosestPoint& onto_recon, double radius) {
  if (!(radius >= 0)) throw Error("twin fit: radius must be >= 0");
  const ExactClosestPoint onto_registered(registered);
  return MeasureCueWith(registered, onto_registered, cue, recon, onto_recon, radius);
}

std::string TwinInDatabase(const Database& db, int entry) {
  const EntryLabel& l = db.label(entry);
  for (const std::string& t : SymmetryTwins(l.anchor)) {
    if (FindEntry(db, l.category, l.instance, t) >= 0) return t;
  }
  return "";
}

void DecideTwin(TwinFit& fit, const TwinFitOptions& options, size_t r) {
  options.Validate();
  fit.anchor = fit.matched_anchor;
  fit.entry = fit.matched_entry;
  fit.switched = fit.compared = false;
  fit.matched_residual = fit.twin_residual = 0;
  double rm = 0, rt = 0, scale = 0;  // scale: the matched side's unsigned residual (signed margins)
  int pairs = 0;
  for (size_t i = 0; i + 1 < fit.sides.size(); i += 2) {  // (matched, twin) per instance
    if (options.instances == 1 && fit.sides[i].instance != fit.matched_instance) continue;
    const std::optional<double> a = SideValue(fit.sides[i], options.direction, r);
    const std::optional<double> b = SideValue(fit.sides[i + 1], options.direction, r);
    const std::optional<double> u = SideValue(fit.sides[i], TwinDirection::kBoth, r);
    if (!a || !b) continue;
    rm += *a, rt += *b, scale += u.value_or(0), ++pairs;
  }
  if (pairs == 0) return;
  fit.compared = true;
  fit.matched_residual = rm, fit.twin_residual = rt;
  const bool better = IsSigned(options.direction) ? rm - rt > options.margin * scale : rt < (1 - options.margin) * rm;
  if (better) {
    fit.switched = true;
    fit.anchor = fit.twin_anchor;
    fit.entry = fit.twin_entry;
  }
}

namespace {

// The sides of the pair: (matched anchor, twin) of each instance that takes part.
std::vector<TwinSide> ChooseSides(const Database& db, const std::vector<Match>& matches, const TwinFit& fit,
                                  const std::string& category, const std::vector<std::string>& instances,
                                  const TwinFitOptions& options) {
  std::vector<std::string> insts{fit.matched_instance};
  if (options.instances == 0) {
    for (const std::string& i : db.instances(category)) {
      if (i == fit.matched_instance) continue;
      if (!instances.empty() && std::find(instances.begin(), instances.end(), i) == instances.end()) continue;
      insts.push_back(i);
    }
  }
  std::vector<TwinSide> sides;
  for (const std::string& inst : insts) {
    const int a = FindEntry(db, category, inst, fit.matched_anchor);
    const int t = FindEntry(db, category, inst, fit.twin_anchor);
    if (a < 0 || t < 0) continue;
    for (int e : {a, t}) {
      TwinSide s;
      s.entry = e;
      s.id = db.label(e).id;
      s.instance = inst;
      s.anchor = db.label(e).anchor;
      s.matched = e == a;
      s.rotation = matches[e].rotation;
      sides.push_back(std::move(s));
    }
  }
  return sides;
}

}  // namespace

TwinFit TwinByFit(const Database& db, const std::vector<Match>& matches, int matched,
                  const std::vector<std::string>& instances, const TriMesh& recon,
                  const std::function<TriMesh(int)>& hung_mesh, const TwinFitOptions& options,
                  const std::vector<double>& radii) {
  options.Validate();
  if (matched < 0 || matched >= db.size()) throw Error("twin fit: no matched database entry");
  DRAPE_CHECK(static_cast<int>(matches.size()) == db.size(), "one match per database entry");
  const auto t0 = Clock::now();
  const EntryLabel& m = db.label(matched);
  TwinFit fit;
  fit.matched_anchor = fit.anchor = m.anchor;
  fit.matched_instance = m.instance;
  fit.matched_entry = fit.entry = matched;
  fit.radii = {options.radius};
  for (double r : radii) {
    if (!(r > 0)) throw Error("twin fit: radii must be > 0");
    if (std::find(fit.radii.begin(), fit.radii.end(), r) == fit.radii.end()) fit.radii.push_back(r);
  }
  fit.twin_anchor = TwinInDatabase(db, matched);
  if (fit.twin_anchor.empty()) {
    fit.note = "no symmetry twin of " + m.anchor + " in the database";
    return fit;
  }
  if (options.direction != TwinDirection::kWhole && CueVertices(db, m.instance).empty()) {
    fit.note = "no cue anchors (neckline or waist) in " + m.instance;
    return fit;
  }
  fit.twin_entry = FindEntry(db, m.category, m.instance, fit.twin_anchor);
  fit.sides = ChooseSides(db, matches, fit, m.category, instances, options);
  registration::RegistrationOptions ro;
  ro.nonrigid = false;
  ro.scale = options.scale;
  ro.grid.threads = 1;
  const ExactClosestPoint onto_recon(recon);
  ParallelFor(static_cast<int>(fit.sides.size()), options.threads, [&](int i) {
    TwinSide& s = fit.sides[i];
    const auto ts = Clock::now();
    try {
      const TriMesh source = TurnedToQuery(hung_mesh(s.entry), s.rotation, db.sectors());
      const TriMesh reg = registration::Register(source, recon, ro).rigid;
      const ExactClosestPoint onto_reg(reg);
      s.whole_fit = 0.5 * (registration::MeasureDirected(reg, onto_recon).mean +
                           registration::MeasureDirected(recon, onto_reg).mean);
      if (!std::isfinite(s.whole_fit)) throw Error("registration gave a non-finite fit");
      const std::vector<int> cue = CueVertices(db, s.instance);
      for (double r : fit.radii) s.cue.push_back(MeasureCueWith(reg, onto_reg, cue, recon, onto_recon, r));
    } catch (const Error& e) {
      s.whole_fit = -1;
      s.cue.clear();
      s.failure = e.what();
    }
    s.seconds = Since(ts);
  });
  DecideTwin(fit, options, 0);
  fit.seconds = Since(t0);
  return fit;
}

void ApplyTwinFit(const Database& db, const std::vector<Match>& matches, const TwinFit& fit, Recognition& r) {
  if (!fit.switched || fit.entry < 0) return;
  const EntryLabel& l = db.label(fit.entry);
  Candidate c;
  c.entry = fit.entry;
  c.id = l.id, c.category = l.category, c.instance = l.instance, c.anchor = l.anchor;
  c.distance = matches[fit.entry].distance;
  c.rotation = matches[fit.entry].rotation;
  c.score = c.distance;  // unless it is among the listed (its ranked score)
  auto it = std::find_if(r.top.begin(), r.top.end(), [&](const Candidate& t) { return t.anchor == l.anchor; });
  if (it != r.top.end()) {
    if (it->entry == c.entry) c.score = it->score;
    r.top.erase(it);
  }
  r.top.insert(r.top.begin(), c);
  r.best = c;
  r.anchor = l.anchor;
}

TwinFit EntryTwinByFit(const Release& release, const Database& db, const Code& q, const RecognizeOptions& o,
                       const std::string& entry, const TwinFitOptions& options, Recognition& r) {
  options.Validate();
  const std::filesystem::path recon = release.EntryPath(entry, "recon.ply");
  if (!std::filesystem::exists(recon))
    throw Error("twin fit: entry " + entry + " has no reconstruction (" + recon.string() + ")");
  std::vector<Match> matches;
  db.matcher().MatchAll(PreparedQuery(q), &matches);
  const bool twin = !TwinInDatabase(db, r.best.entry).empty();
  const TwinFit fit = TwinByFit(db, matches, r.best.entry, o.instances, twin ? ReadMesh(recon) : TriMesh{},
                                ReleaseHungMeshes(release, db), options);
  ApplyTwinFit(db, matches, fit, r);
  return fit;
}

Json ToJson(const TwinFitOptions& o) {
  return Json{{"radius", o.radius},
              {"direction", TwinDirectionName(o.direction)},
              {"instances", o.instances == 1 ? Json("matched") : Json("all")},
              {"margin", o.margin},
              {"scale", o.scale},
              {"registration", "rigid only (scale + ICP), hang.ply turned by its Eq. match rotation onto recon.ply"}};
}

Json ToJson(const TwinFit& fit) {
  auto value = [](double v) { return v >= 0 ? Json(v) : Json(nullptr); };
  auto compared = [&](double v) { return fit.compared ? Json(v) : Json(nullptr); };
  Json sides = Json::array();
  for (const TwinSide& s : fit.sides) {
    Json cue = Json::array();
    for (size_t r = 0; r < s.cue.size(); ++r) {
      cue.push_back({{"radius", fit.radii[r]},
                     {"db_to_recon", value(s.cue[r].db_to_recon)},
                     {"recon_to_db", value(s.cue[r].recon_to_db)},
                     {"db_signed", s.cue[r].db_samples > 0 ? Json(s.cue[r].db_signed) : Json(nullptr)},
                     {"recon_signed", s.cue[r].recon_samples > 0 ? Json(s.cue[r].recon_signed) : Json(nullptr)},
                     {"db_samples", s.cue[r].db_samples},
                     {"recon_samples", s.cue[r].recon_samples}});
    }
    Json j{{"entry", s.id},
           {"anchor", s.anchor},
           {"matched", s.matched},
           {"rotation", s.rotation},
           {"whole_fit", value(s.whole_fit)},
           {"cue", cue}};
    if (!s.failure.empty()) j["failure"] = s.failure;
    sides.push_back(std::move(j));
  }
  return Json{{"matched_anchor", fit.matched_anchor},
              {"twin_anchor", fit.twin_anchor.empty() ? Json(nullptr) : Json(fit.twin_anchor)},
              {"anchor", fit.anchor},
              {"switched", fit.switched},
              {"matched_residual", compared(fit.matched_residual)},
              {"twin_residual", compared(fit.twin_residual)},
              {"sides", sides},
              {"note", fit.note},
              {"seconds", fit.seconds}};
}

namespace {

// One query of the evaluation or the selection.
struct TwinQuery {
  const LabelledCode* query = nullptr;
  std::vector<std::string> instances;  // the pose search's (empty = all)
  std::string bits_anchor;             // the pose match's answer
  TwinFit fit;
  double seconds = 0;   // the recon's reading and the fit (timing only)
  std::string failure;  // the pair could not be measured
};

void RunTwinQuery(const Release& release, const Database& db, const Recognizer& rec,
                  const std::function<TriMesh(int)>& hung, const TwinFitOptions& options,
                  const std::vector<double>& radii, TwinQuery& q) {
  const EntryLabel& l = q.query->label;
  if (!db.HasCategory(l.category)) {
    q.failure = "the database has no entry of category " + l.category;
    return;
  }
  std::vector<Match> matches;
  const PreparedQuery pq(q.query->code);
  db.matcher().MatchAll(pq, &matches);
  RecognizeOptions o;
  o.category = l.category;
  o.instances = q.instances;
  o.query_height = l.height;
  const Recognition r = rec.Rank(pq, matches, o);
  q.bits_anchor = r.anchor;
  q.fit.matched_anchor = q.fit.anchor = r.anchor;
  const auto t0 = Clock::now();
  try {
    TwinFitOptions one = options;
    one.threads = 1;  // parallel over queries instead
    const bool twin = !TwinInDatabase(db, r.best.entry).empty();
    const TriMesh recon = twin ? ReadMesh(release.EntryPath(l.id, "recon.ply")) : TriMesh{};
    q.fit = TwinByFit(db, matches, r.best.entry, q.instances, recon, hung, one, radii);
  } catch (const Error& e) {
    q.failure = e.what();
  }
  q.seconds = Since(t0);
}

bool TwinCredited(const std::string& anchor, const std::string& truth) {
  const std::vector<std::string> t = SymmetryTwins(truth);
  return anchor == truth || std::find(t.begin(), t.end(), anchor) != t.end();
}

struct Rate {
  int n = 0, right = 0;
  void Add(bool ok) { ++n, right += ok; }
  Json Value() const { return n ? Json(double(right) / n) : Json(nullptr); }
};

struct TwinAcc {
  Rate strict_bits, strict_fit, twin_bits, twin_fit;
  int compared = 0, switched = 0, switched_right = 0, switched_wrong = 0;
  double seconds = 0;
  void Add(const TwinQuery& q) {
    const std::string& truth = q.query->label.anchor;
    strict_bits.Add(q.bits_anchor == truth), strict_fit.Add(q.fit.anchor == truth);
    twin_bits.Add(TwinCredited(q.bits_anchor, truth)), twin_fit.Add(TwinCredited(q.fit.anchor, truth));
    compared += q.fit.compared;
    if (q.fit.switched) ++switched, switched_right += q.fit.anchor == truth, switched_wrong += q.bits_anchor == truth;
    seconds += q.seconds;
  }
  Json ToJson(const std::string& name) const {
    return Json{{"category", name},
                {"queries", strict_bits.n},
                {"strict", {{"bits", strict_bits.Value()}, {"twin_fit", strict_fit.Value()}}},
                {"twin_credited", {{"bits", twin_bits.Value()}, {"twin_fit", twin_fit.Value()}}},
                {"compared", compared},
                {"switched", switched},
                {"switched_to_right", switched_right},
                {"switched_from_right", switched_wrong},
                {"seconds_per_query", strict_bits.n ? Json(seconds / strict_bits.n) : Json(nullptr)}};
  }
};

}  // namespace

Json EvaluateTwinFit(const Release& release, const Database& db, const Weights* weights,
                     const std::vector<EvalQuery>& queries, const TwinFitOptions& options) {
  options.Validate();
  const auto t0 = Clock::now();
  const Recognizer rec(db, weights);
  const auto hung = ReleaseHungMeshes(release, db);
  std::vector<TwinQuery> qs(queries.size());
  for (size_t i = 0; i < queries.size(); ++i) qs[i].query = &queries[i].query;
  ParallelFor(static_cast<int>(qs.size()), options.threads,
              [&](int i) { RunTwinQuery(release, db, rec, hung, options, {}, qs[i]); });
  std::map<std::string, TwinAcc> acc;
  TwinAcc all;
  Json per_query = Json::array();
  for (const TwinQuery& q : qs) {
    acc[q.query->label.category].Add(q), all.Add(q);
    Json j{{"id", q.query->label.id},
           {"category", q.query->label.category},
           {"anchor", q.query->label.anchor},
           {"bits", q.bits_anchor},
           {"twin_fit", ToJson(q.fit)}};
    if (!q.failure.empty()) j["failure"] = q.failure;
    per_query.push_back(std::move(j));
  }
  Json cats = Json::array();
  for (const auto& [name, a] : acc) cats.push_back(a.ToJson(name));
  cats.push_back(all.ToJson("all"));
  return Json{{"options", ToJson(options)},
              {"metric", weights ? "learned (Eq. bestmatch; unweighted for a category without weights)"
                                 : "unweighted (Eq. match)"},
              {"protocol", "category known, every database instance (the pose table's strict column)"},
              {"categories", cats},
              {"per_query", per_query},
              {"wall_seconds", Since(t0)},
              {"threads", options.threads <= 0 ? HardwareThreads() : options.threads}};
}

namespace {

const std::vector<double> kSelectionRadii{0.03, 0.04, 0.06, 0.08, 0.10, 0.12, 0.16, 0.20};

// The selection grid, simplest first: the matched instance, no margin, then the rest.
std::vector<std::pair<TwinFitOptions, size_t>> SelectionGrid() {
  std::vector<std::pair<TwinFitOptions, size_t>> grid;
  for (int inst : {1, 0}) {
    for (double margin : {0.0, 0.05, 0.1, 0.2}) {
      for (TwinDirection d :
           {TwinDirection::kBoth, TwinDirection::kDbToRecon, TwinDirection::kReconToDb, TwinDirection::kSigned,
            TwinDirection::kDbSigned, TwinDirection::kReconSigned, TwinDirection::kWhole}) {
        for (size_t r = 0; r < kSelectionRadii.size(); ++r) {
          if (d == TwinDirection::kWhole && r > 0) break;  // no radius
          TwinFitOptions o;
          o.instances = inst, o.margin = margin, o.direction = d, o.radius = kSelectionRadii[r];
          grid.emplace_back(o, r);
        }
      }
    }
  }
  return grid;
}

// ok[i][g]: query i strictly right with grid setting g (the bits' answer where no pair
// was compared).
std::vector<std::vector<char>> GridAnswers(std::vector<TwinQuery>& qs,
                                           const std::vector<std::pair<TwinFitOptions, size_t>>& grid) {
  std::vector<std::vector<char>> ok(qs.size(), std::vector<char>(grid.size(), 0));
  for (size_t i = 0; i < qs.size(); ++i) {
    TwinQuery& q = qs[i];
    const std::string& truth = q.query->label.anchor;
    for (size_t g = 0; g < grid.size(); ++g) {
      if (q.fit.sides.empty() || !q.failure.empty()) {
        ok[i][g] = q.bits_anchor == truth;
        continue;
      }
      DecideTwin(q.fit, grid[g].first, grid[g].second);
      ok[i][g] = q.fit.anchor == truth;
    }
  }
  return ok;
}

// The selection's queries: `calibration` against every instance, each of `train` (the
// database's entries) against the other instances of its category; `left_out` counts
// those whose category has no other instance (they cannot be right).
std::vector<TwinQuery> SelectionQueries(const Database& db, const std::vector<LabelledCode>& calibration,
                                        const std::vector<LabelledCode>& train, int& left_out) {
  std::vector<TwinQuery> qs;
  for (const LabelledCode& c : calibration) qs.emplace_back().query = &c;
  for (const LabelledCode& c : train) {
    std::vector<std::string> others;
    for (const std::string& i : db.instances(c.label.category)) {
      if (i != c.label.instance) others.push_back(i);
    }
    if (others.empty()) {
      ++left_out;
      continue;
    }
    TwinQuery& q = qs.emplace_back();
    q.query = &c;
    q.instances = std::move(others);
  }
  return qs;
}

}  // namespace

Json SelectTwinFit(const Release& release, const Database& db, const Weights* weights,
                   const std::vector<LabelledCode>& calibration, int threads) {
  const auto t0 = Clock::now();
  const Recognizer rec(db, weights);
  std::vector<LabelledCode> train(db.size());
  for (int i = 0; i < db.size(); ++i) train[i] = {db.label(i), db.code(i)};
  int left_out = 0;
  std::vector<TwinQuery> qs = SelectionQueries(db, calibration, train, left_out);
  TwinFitOptions largest;
  largest.instances = 0;
  largest.radius = kSelectionRadii[0];
  const auto hung = ReleaseHungMeshes(release, db);
  ParallelFor(static_cast<int>(qs.size()), threads,
              [&](int i) { RunTwinQuery(release, db, rec, hung, largest, kSelectionRadii, qs[i]); });
  const auto grid = SelectionGrid();
  const std::vector<std::vector<char>> ok = GridAnswers(qs, grid);
  std::vector<int> right(grid.size(), 0);
  std::vector<std::map<std::string, int>> by_cat(grid.size());
  int bits_right = 0, compared = 0;
  double seconds = 0;
  std::map<std::string, int> bits_by_cat, n_by_cat;
  for (size_t i = 0; i < qs.size(); ++i) {
    const std::string& cat = qs[i].query->label.category;
    ++n_by_cat[cat];
    bits_right += qs[i].bits_anchor == qs[i].query->label.anchor;
    bits_by_cat[cat] += qs[i].bits_anchor == qs[i].query->label.anchor;
    compared += !qs[i].fit.sides.empty();
    seconds += qs[i].seconds;
    for (size_t g = 0; g < grid.size(); ++g) right[g] += ok[i][g], by_cat[g][cat] += ok[i][g];
  }
  const int n = static_cast<int>(qs.size());
  const int chosen = MostRight(right);
  Json per_query = Json::array();
  for (TwinQuery& q : qs) {
    Json j{{"id", q.query->label.id},
           {"category", q.query->label.category},
           {"anchor", q.query->label.anchor},
           {"bits", q.bits_anchor}};
    if (!q.fit.sides.empty()) {
      DecideTwin(q.fit, grid[chosen].first, grid[chosen].second);  // the chosen setting's answer
      j["twin_fit"] = ToJson(q.fit);
    }
    if (!q.instances.empty()) j["instances"] = q.instances;
    if (!q.failure.empty()) j["failure"] = q.failure;
    per_query.push_back(std::move(j));
  }
  Json rows = Json::array();
  for (size_t g = 0; g < grid.size(); ++g)
    rows.push_back({{"options", ToJson(grid[g].first)}, {"right", right[g]}, {"right_by_category", by_cat[g]}});
  const double p = n ? double(bits_right) / n : 0;
  return Json{{"queries", n},
              {"queries_by_category", n_by_cat},
              {"left_out", left_out},
              {"compared", compared},
              {"bits", {{"right", bits_right}, {"right_by_category", bits_by_cat}}},
              {"standard_error", std::sqrt(p * (1 - p) / std::max(n, 1)) * n},
              {"chosen", ToJson(grid[chosen].first)},
              {"chosen_right", right[chosen]},
              {"chosen_right_by_category", by_cat[chosen]},
              {"rule", "the setting with the most right strict answers (ties: the first, simplest first)"},
              {"nested_leave_one_out",
               {{"right", NestedLeaveOneOut(ok, [](const std::vector<int>& r, int) { return MostRight(r); })},
                {"what",
                 "each query answered by the setting the rule chooses on the other queries: what the "
                 "selection itself is worth, beside the bits' count"}}},
              {"grid", rows},
              {"per_query", per_query},
              {"seconds_per_query", n ? seconds / n : 0.0},
              {"wall_seconds", Since(t0)},
              {"threads", threads <= 0 ? HardwareThreads() : threads}};
}

}  // namespace drape::recognition
