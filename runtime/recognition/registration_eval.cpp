// The registration table of `drape eval` (see registration_eval.h).
#include "runtime/recognition/registration_eval.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>

#include "common/error.h"
#include "common/field_error.h"
#include "common/files.h"
#include "common/parallel.h"
#include "common/timing.h"
#include "garments/io.h"
#include "garments/render.h"
#include "runtime/recognition/release_source.h"

namespace drape::recognition {

namespace fs = std::filesystem;
namespace reg = drape::registration;

void RegistrationEvalOptions::Validate() const {
  registration.Validate();
  if (max_pairs_per_category < 0) BadField(max_pairs_per_category, "max_pairs_per_category", "must be >= 0 (0 = all)");
}

namespace {

// The paper's per-garment rows and average (Table "Registration results"): S→T R, T→S R,
// S→T R+N, T→S R+N, metres.
Json PaperTable() {
  auto row = [](const char* name, double a, double b, double c, double d) {
    return Json{
        {"garment", name}, {"s_to_t_rigid", a}, {"t_to_s_rigid", b}, {"s_to_t_nonrigid", c}, {"t_to_s_nonrigid", d}};
  };
  return Json{{"rows", Json::array({row("Long-Sleeve T-Shirt 1", 0.0251, 0.0188, 0.0073, 0.0129),
                                    row("Long-Sleeve T-Shirt 2", 0.0171, 0.0218, 0.0151, 0.0213),
                                    row("Long Pants 1", 0.0099, 0.0652, 0.0060, 0.0648),
                                    row("Long Pants 2", 0.0164, 0.0221, 0.0044, 0.0172),
                                    row("Shorts", 0.0238, 0.0149, 0.0081, 0.0092)})},
              {"average", row("Average", 0.0185, 0.0256, 0.0070, 0.0250)}};
}

struct Pair {
  const Release::EntryInfo* test = nullptr;
  EntryLabel test_label;
  int db_index = -1;
  std::string source_choice;  // "recognised" | "first_instance"
};

struct PairOutcome {
  bool ok = false;
  std::string failure;
  reg::RegistrationEvaluation ev;
  Vec3 truth = Vec3::Zero();
  bool has_truth = false;
  std::optional<RegistrationFigure> figure;
  double read_seconds = 0;
};

// The database entry recognition matched for query `id` if its anchor was right.
std::map<std::string, std::string> RecognisedEntries(const Json& per_query) {
  std::map<std::string, std::string> out;
  if (!per_query.is_array()) return out;
  for (const Json& q : per_query) {
    if (!q.contains("category_known")) continue;
    const Json& ck = q["category_known"];
    for (const char* key : {"both/learned", "both/unweighted"}) {
      if (ck.contains(key) && ck[key].value("correct", false)) {
        out[q.value("id", "")] = ck[key].value("entry", "");
        break;
      }
    }
  }
  return out;
}

// Accumulates the mean of the four distances, anchor errors and times over pairs.
struct Sum {
  int n = 0, anchors = 0;
  double st_r = 0, ts_r = 0, st_n = 0, ts_n = 0, a_r = 0, a_n = 0;
  double grid = 0, icp = 0, nonrigid = 0, total = 0;
  std::vector<double> anchor_r, anchor_n;  // cm, for the median (one bad pair dominates a mean)
  int warned = 0;                          // pairs whose registration reported a warning
  void Add(const PairOutcome& o) {
    ++n;
    warned += !o.ev.report.warnings.empty();
    st_r += o.ev.s_to_t_rigid.mean, ts_r += o.ev.t_to_s_rigid.mean;
    st_n += o.ev.s_to_t_nonrigid.mean, ts_n += o.ev.t_to_s_nonrigid.mean;
    grid += o.ev.report.grid_seconds, icp += o.ev.report.icp_seconds;
    nonrigid += o.ev.report.nonrigid_seconds, total += o.ev.seconds;
    if (o.ev.anchors_with_truth > 0) {
      ++anchors;
      a_r += 100 * o.ev.anchor_error_rigid, a_n += 100 * o.ev.anchor_error_nonrigid;
      anchor_r.push_back(100 * o.ev.anchor_error_rigid), anchor_n.push_back(100 * o.ev.anchor_error_nonrigid);
    }
  }
  Json ToJson(const std::string& name) const {
    auto mean = [&](double s, int k) { return k > 0 ? Json(s / k) : Json(nullptr); };
    auto median = [](std::vector<double> v) {
      if (v.empty()) return Json(nullptr);
      std::sort(v.begin(), v.end());
      const size_t h = v.size() / 2;
      return Json(v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]));
    };
    return Json{{"garment", name},
                {"pairs", n},
                {"s_to_t_rigid", mean(st_r, n)},
                {"t_to_s_rigid", mean(ts_r, n)},
                {"s_to_t_nonrigid", mean(st_n, n)},
                {"t_to_s_nonrigid", mean(ts_n, n)},
                {"anchor_error_cm",
                 {{"rigid", mean(a_r, anchors)},
                  {"nonrigid", mean(a_n, anchors)},
                  {"rigid_median", median(anchor_r)},
                  {"nonrigid_median", median(anchor_n)},
                  {"pairs", anchors}}},
                {"pairs_with_warnings", warned},
                {"timing",
                 {{"grid_seconds", mean(grid, n)},
                  {"icp_seconds", mean(icp, n)},
                  {"nonrigid_seconds", mean(nonrigid, n)},
                  {"seconds_per_registration", mean(total, n)}}}};
  }
};

// The source for a test entry: the train entry recognition matched (when it did), else
// the true anchor's train entry of the first instance (by name) that has it; -1 if none.
int SourceFor(const Database& db, const EntryLabel& l, const std::string& recognised_id,
              const std::map<std::string, int>& db_by_id, std::string* choice) {
  if (auto it = db_by_id.find(recognised_id); !recognised_id.empty() && it != db_by_id.end()) {
    *choice = "recognised";
    return it->second;
  }
  if (!db.HasCategory(l.category)) return -1;
  int best = -1;
  for (int i : db.EntriesOf(l.category)) {
    const EntryLabel& d = db.label(i);
    if (d.anchor != l.anchor) continue;
    if (best < 0 || d.instance < db.label(best).instance ||
        (d.instance == db.label(best).instance && d.id < db.label(best).id)) {
      best = i;
    }
  }
  *choice = "first_instance";
  return best;
}

// Pairs, in entry-id order (release entries are sorted by id); the entries left out go
// to `skipped` with the reason, or count in `limited` (max_pairs_per_category).
std::vector<Pair> ChoosePairs(const Release& release, const Database& db, const Json& per_query,
                              const std::string& split, int max_per_category, Json& skipped, int& limited) {
  const std::map<std::string, std::string> recognised = RecognisedEntries(per_query);
  std::map<std::string, int> db_by_id;
  for (int i = 0; i < db.size(); ++i) db_by_id[db.label(i).id] = i;
  std::vector<Pair> pairs;
  std::map<std::string, int> per_category;
  for (const auto& e : release.entries()) {
    if (e.split != split) continue;
    if (e.failed) {
      skipped.push_back({{"id", e.id}, {"reason", "build failed: " + e.failure}});
      continue;
    }
    EntryLabel l;
    try {
      l = LabelFromEntry(e);
    } catch (const Error& err) {
      skipped.push_back({{"id", e.id}, {"reason", err.what()}});
      continue;
    }
    if (max_per_category > 0 && per_category[l.category] >= max_per_category) continue;  // counted below
    Pair p;
    p.test = &e;
    p.test_label = l;
    auto it = recognised.find(e.id);
    p.db_index = SourceFor(db, l, it != recognised.end() ? it->second : "", db_by_id, &p.source_choice);
    if (p.db_index < 0) {
      skipped.push_back({{"id", e.id}, {"reason", "no train entry of " + l.category + " / " + l.anchor}});
      continue;
    }
    ++per_category[l.category];
    pairs.push_back(std::move(p));
  }
  limited = 0;
  if (max_per_category > 0) {
    for (const auto& e : release.entries()) limited += e.split == split;
    limited -= static_cast<int>(pairs.size() + skipped.size());
  }
  return pairs;
}

// One registration: database entry's hang.ply onto the test entry's recon.ply, with the
// anchor's truth when the test entry has it; the figure's meshes when asked for.
PairOutcome RegisterPair(const Release& release, const Pair& p, const EntryLabel& d, const reg::RegistrationOptions& ro,
                         bool wants_figure) {
  PairOutcome o;
  try {
    const auto t0 = Clock::now();
    const TriMesh source = ReadMesh(release.EntryPath(d.id, "hang.ply"));
    const TriMesh target = ReadMesh(release.EntryPath(p.test->id, "recon.ply"));
    std::optional<Vec3> truth = HungVertex(release, p.test->id, p.test_label.anchor_vertex);
    o.read_seconds = Since(t0);
    std::vector<reg::AnchorPair> anchors;
    if (d.anchor_vertex >= 0) {
      reg::AnchorPair a;
      a.label = d.anchor;
      a.source_vertex = d.anchor_vertex;
      if (truth) a.has_truth = true, a.truth = *truth;
      anchors.push_back(a);
    }
    o.has_truth = truth.has_value();
    if (truth) o.truth = *truth;
    reg::RegistrationResult rr;
    o.ev = reg::RegisterAndEvaluate(source, target, anchors, ro, &rr);
    o.ok = true;
    if (wants_figure) {
      RegistrationFigure f;
      f.category = p.test_label.category;
      f.caption = p.test_label.category + ": source " + d.id + " (" + d.instance + ", " + p.source_choice +
                  ") -> target " + p.test->id + " recon";
      f.source = source;
      f.target = target;
      f.rigid = rr.rigid;
      f.nonrigid = rr.nonrigid;
      if (!o.ev.anchors.empty() && o.has_truth) {
        f.has_anchor = true;
        f.anchor_truth = o.truth;
        f.anchor_rigid = o.ev.anchors[0].rigid;
        f.anchor_nonrigid = o.ev.anchors[0].nonrigid;
      }
      o.figure = std::move(f);
    }
  } catch (const NumericalError& err) {
    o.failure = std::string("numerical: ") + err.what();
  } catch (const Error& err) {
    o.failure = err.what();
  }
  return o;
}

// One row of the table's "pairs".
Json PairJson(const Pair& p, const EntryLabel& d, const PairOutcome& o) {
  Json j{{"test", p.test->id},
         {"category", p.test_label.category},
         {"test_instance", p.test_label.instance},
         {"anchor", p.test_label.anchor},
         {"source", d.id},
         {"source_instance", d.instance},
         {"source_choice", p.source_choice},
         {"ok", o.ok}};
  if (!o.ok) {
    j["failure"] = o.failure;
    return j;
  }
  j["s_to_t_rigid"] = o.ev.s_to_t_rigid.mean;
  j["t_to_s_rigid"] = o.ev.t_to_s_rigid.mean;
  j["s_to_t_nonrigid"] = o.ev.s_to_t_nonrigid.mean;
  j["t_to_s_nonrigid"] = o.ev.t_to_s_nonrigid.mean;
  if (o.ev.anchors_with_truth > 0) {
    j["anchor_error_cm"] = {{"rigid", 100 * o.ev.anchor_error_rigid}, {"nonrigid", 100 * o.ev.anchor_error_nonrigid}};
    j["anchor_truth"] = PointJson(o.truth);
    // Test entries are hung with a grasp offset, so their true anchor is not at the grip
    // (origin) while a database anchor (offset 0) is: a transfer to the grip is off by this much.
    j["anchor_truth_from_grasp_cm"] = 100 * o.truth.norm();
  } else {
    j["anchor_error_cm"] = nullptr;
  }
  j["registration"] = reg::ToJson(o.ev);
  return j;
}

Json OptionsJson(const reg::RegistrationOptions& ro, int max_pairs_per_category) {
  return Json{{"scale", ro.scale},
              {"nonrigid", ro.nonrigid},
              {"grid_cells", ro.grid.cells},
              {"kappa", ro.kappa},
              {"beta", ro.beta},
              {"alpha", ro.alpha},
              {"refined_fit", ro.refined_fit},
              {"lm_max_iterations", ro.lm.max_iterations},
              {"max_pairs_per_category", max_pairs_per_category},
              {"meshes",
               "source = database entry's hang.ply, target = test entry's recon.ply, full resolution "
               "(no decimation)"}};
}

}  // namespace

RegistrationEvalResult EvaluateRegistration(const Release& release, const Database& db, const Json& per_query,
                                            const std::string& split, const RegistrationEvalOptions& options) {
  options.Validate();
  const auto t_all = Clock::now();
  Json skipped = Json::array();
  int limited = 0;
  const std::vector<Pair> pairs =
      ChoosePairs(release, db, per_query, split, options.max_pairs_per_category, skipped, limited);

  // One registration per pair; a figure for the first pair of each category.
  std::set<std::string> figure_for;
  std::vector<bool> wants_figure(pairs.size(), false);
  for (size_t i = 0; i < pairs.size(); ++i) {
    wants_figure[i] = figure_for.insert(pairs[i].test_label.category).second;
  }
  reg::RegistrationOptions ro = options.registration;
  ro.grid.threads = 1;  // parallel over pairs instead
  std::vector<PairOutcome> out(pairs.size());
  ParallelFor(static_cast<int>(pairs.size()), options.threads, [&](int i) {
    out[i] = RegisterPair(release, pairs[i], db.label(pairs[i].db_index), ro, wants_figure[i]);
  });

  RegistrationEvalResult result;
  Json pj = Json::array();
  std::map<std::string, Sum> by_garment;  // "category / test instance"
  std::map<std::string, Sum> by_category;
  Sum all;
  int failed = 0;
  double read_seconds = 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const Pair& p = pairs[i];
    const PairOutcome& o = out[i];
    read_seconds += o.read_seconds;
    pj.push_back(PairJson(p, db.label(p.db_index), o));
    if (!o.ok) {
      ++failed;
      continue;
    }
    by_garment[p.test_label.category + " / " + p.test_label.instance].Add(o);
    by_category[p.test_label.category].Add(o);
    all.Add(o);
    if (o.figure) result.figures.push_back(*o.figure);
  }
  std::sort(result.figures.begin(), result.figures.end(),
            [](const RegistrationFigure& a, const RegistrationFigure& b) { return a.category < b.category; });
  Json garments = Json::array(), categories = Json::array();
  for (const auto& [name, s] : by_garment) garments.push_back(s.ToJson(name));
  for (const auto& [name, s] : by_category) categories.push_back(s.ToJson(name));
  result.table = Json{{"split", split},
                      {"protocol",
                       "pose known: source = train entry of the true category and anchor (the entry "
                       "recognition matched when right, else the first instance by name)"},
                      {"pairs", pj},
                      {"garments", garments},
                      {"categories", categories},
                      {"average", all.ToJson("Average")},
                      {"failed", failed},
                      {"skipped", skipped},
                      {"limited_out", limited},
                      {"options", OptionsJson(ro, options.max_pairs_per_category)},
                      {"paper", PaperTable()},
                      {"timing",
                       {{"wall_seconds", Since(t_all)},
                        {"read_seconds", read_seconds},
                        {"threads", options.threads <= 0 ? HardwareThreads() : options.threads}}}};
  return result;
}

// ---------------------------------------------------------------- figures
namespace {

// Drawn with garments/render.h like the build's previews. One view for all four panels
// so they compare.
constexpr int kPanelW = 320, kPanelH = 400, kTitleH = 28;

cv::Point Px(const cv::Point2d& p) { return {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y))}; }

void DrawMesh(cv::Mat& img, const TriMesh& mesh, const OrthoView& view, const cv::Scalar& base) {
  if (mesh.NumFaces() > 0) DrawShadedMesh(img, mesh, view, base);
}

// Target drawn as a thin grey backdrop under a registered source: shows the fit.
void DrawOverlay(cv::Mat& img, const TriMesh& target, const TriMesh& source, const OrthoView& view) {
  DrawMesh(img, target, view, cv::Scalar(200, 200, 200));
  DrawMesh(img, source, view, cv::Scalar(90, 150, 220));
}

cv::Mat Panel(const std::string& label) {
  cv::Mat p(kPanelH, kPanelW, CV_8UC3, cv::Scalar(245, 245, 245));
  cv::putText(p, label, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {40, 40, 40}, 1, cv::LINE_AA);
  return p;
}

}  // namespace

std::string RenderRegistrationFigure(const RegistrationFigure& f) {
  Eigen::AlignedBox3d box(Vec3::Zero(), Vec3::Zero());
  for (const TriMesh* m : {&f.source, &f.target, &f.rigid, &f.nonrigid}) {
    if (m->NumVertices() > 0) box.extend(Bounds(*m));
  }
  OrthoView v{kPanelW, kPanelH};
  v.y_offset = 10;  // room for the caption above
  const Vec3 size = box.sizes();
  v.scale = 0.85 * std::min(kPanelW / std::max(size.x(), 1e-3), (kPanelH - 40) / std::max(size.y(), 1e-3));
  v.cx = box.center().x();
  v.cy = box.center().y();
  cv::Mat a = Panel("source S (database hang.ply)");
  DrawMesh(a, f.source, v, cv::Scalar(90, 150, 220));
  cv::Mat b = Panel("target T (recon.ply)");
  DrawMesh(b, f.target, v, cv::Scalar(120, 180, 120));
  cv::Mat c = Panel("R: rigid (over T in grey)");
  DrawOverlay(c, f.target, f.rigid, v);
  cv::Mat d = Panel("R+N: rigid + non-rigid");
  DrawOverlay(d, f.target, f.nonrigid, v);
  if (f.has_anchor) {
    // Green cross: true anchor on the test garment; red circle: transferred anchor.
    for (cv::Mat* m : {&b, &c, &d}) {
      cv::drawMarker(*m, Px(v.Project(f.anchor_truth)), {0, 160, 0}, cv::MARKER_CROSS, 14, 2);
    }
    cv::circle(c, Px(v.Project(f.anchor_rigid)), 7, {0, 0, 220}, 2, cv::LINE_AA);
    cv::circle(d, Px(v.Project(f.anchor_nonrigid)), 7, {0, 0, 220}, 2, cv::LINE_AA);
  }
  cv::Mat row;
  cv::hconcat(std::vector<cv::Mat>{a, b, c, d}, row);
  cv::Mat out(row.rows + 2 * kTitleH, row.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  row.copyTo(out(cv::Rect(0, kTitleH, row.cols, row.rows)));
  cv::putText(out, f.caption, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  cv::putText(out,
              "orthographic, object frame seen from +z; green cross = true anchor, red circle = transferred anchor",
              {8, row.rows + kTitleH + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {60, 60, 60}, 1, cv::LINE_AA);
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", out, png)) throw Error("registration figure: PNG encoding failed");
  return std::string(png.begin(), png.end());
}

std::vector<std::string> WriteRegistrationFigures(const RegistrationEvalResult& result, const fs::path& dir) {
  std::vector<std::string> names;
  for (const RegistrationFigure& f : result.figures) {
    std::string safe;
    for (char ch : f.category)
      safe += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_') ? ch : '_';
    const std::string name = "registration_" + safe + ".png";
    WriteFileAtomic(dir / name, RenderRegistrationFigure(f));
    names.push_back(name);
  }
  return names;
}

}  // namespace drape::recognition
