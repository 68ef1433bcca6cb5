#include "runtime/unfolding/figures.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/files.h"
#include "garments/render.h"
#include "runtime/tabletop/table.h"
#include "runtime/unfolding/objective.h"

namespace drape::unfolding {

namespace fs = std::filesystem;

namespace {

constexpr int kW = 400, kH = 480;
const cv::Scalar kWhite(255, 255, 255), kBlack(0, 0, 0), kRed(40, 40, 220), kGreen(40, 170, 40), kBlue(200, 90, 30),
    kGrey(190, 190, 190);

// A view fitting the x–y extent of `pts` into a kW × kH panel (margins for the title).
OrthoView Fit(const std::vector<Vec3>& pts) {
  Eigen::AlignedBox3d b;
  for (const Vec3& p : pts) b.extend(p);
  OrthoView v;
  v.width = kW, v.height = kH;
  const Vec3 d = b.sizes().cwiseMax(1e-3);
  v.scale = std::min((kW - 40) / d.x(), (kH - 80) / d.y());
  v.cx = b.center().x(), v.cy = b.center().y();
  v.y_offset = 15;
  return v;
}
std::vector<Vec3> Points(const TriMesh& m) {
  std::vector<Vec3> out;
  out.reserve(m.NumVertices());
  for (int i = 0; i < m.NumVertices(); ++i) out.push_back(m.V.row(i).transpose());
  return out;
}

void Title(cv::Mat& img, const std::string& s, int line = 0) {
  cv::putText(img, s, cv::Point(8, 20 + 18 * line), cv::FONT_HERSHEY_SIMPLEX, 0.45, kBlack, 1, cv::LINE_AA);
}
void Dot(cv::Mat& img, const cv::Point2d& p, const cv::Scalar& c, int r = 6) {
  cv::circle(img, cv::Point(int(std::lround(p.x)), int(std::lround(p.y))), r, c, cv::FILLED, cv::LINE_AA);
  cv::circle(img, cv::Point(int(std::lround(p.x)), int(std::lround(p.y))), r, kBlack, 1, cv::LINE_AA);
}

// Blue (0) … red (1).
cv::Scalar Heat(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return cv::Scalar(255 * (1 - t), 120 * (1 - std::abs(2 * t - 1)), 255 * t);
}

// Faces far to near, each in the heat colour of its vertices' mean score, shaded.
void DrawScored(cv::Mat& img, const TriMesh& m, const std::vector<double>& score, const OrthoView& v) {
  const Points3 n = FaceNormals(m), c = FaceCentroids(m);
  std::vector<int> order(m.NumFaces());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return c(a, 2) < c(b, 2); });
  const Vec3 light = Vec3(0.3, 0.5, 1.0).normalized();
  for (int f : order) {
    double s = 0;
    cv::Point pts[3];
    for (int k = 0; k < 3; ++k) {
      s += score.empty() ? 0 : score[m.F(f, k)] / 3;
      const cv::Point2d p = v.Project(m.V.row(m.F(f, k)).transpose());
      pts[k] = cv::Point(int(std::lround(p.x * 16)), int(std::lround(p.y * 16)));
    }
    cv::fillConvexPoly(img, pts, 3, Heat(s) * (0.4 + 0.6 * std::abs(n.row(f).dot(light))), cv::LINE_8, 4);
  }
}

// The garment's pattern (front layer, uv), with marks.
struct Mark {
  Vec2 uv;
  cv::Scalar colour;
  std::string label;
};
cv::Mat PatternPanel(const Garment& g, const std::vector<Mark>& marks, const std::string& title) {
  cv::Mat img(kH, kW, CV_8UC3, kWhite);
  TriMesh flat;
  flat.F = g.mesh.F;
  flat.V.resize(g.mesh.NumVertices(), 3);
  for (int i = 0; i < g.mesh.NumVertices(); ++i) {
    const Vec2 uv = g.uv.rows() == g.mesh.NumVertices() ? Vec2(g.uv.row(i)) : Vec2(g.mesh.V(i, 0), g.mesh.V(i, 1));
    flat.V.row(i) = Vec3(uv.x(), uv.y(), 0).transpose();
  }
  const OrthoView v = Fit(Points(flat));
  DrawShadedMesh(img, flat, v, kGrey);
  for (const Mark& m : marks) {
    const cv::Point2d p = v.Project(Vec3(m.uv.x(), m.uv.y(), 0));
    Dot(img, p, m.colour);
    if (!m.label.empty())
      cv::putText(img, m.label, cv::Point(int(p.x) + 8, int(p.y) - 6), cv::FONT_HERSHEY_SIMPLEX, 0.4, kBlack, 1,
                  cv::LINE_AA);
  }
  Title(img, title);
  return img;
}

std::vector<Mark> DesiredMarks(const Garment& g, const std::string& category) {
  std::vector<Mark> out;
  for (const DesiredPair& d : DesiredPairsFor(category))
    for (const std::string& l : {d.first, d.second})
      if (const Anchor* a = g.FindAnchor(l)) out.push_back({a->uv, kGreen, ""});
  return out;
}

// Plot of the IR ranges (blue, m) and the LoG response (red, scaled), minimum marked.
cv::Mat IrPanel(const Step& s) {
  cv::Mat img(kH, kW, CV_8UC3, kWhite);
  Title(img, "IR scan: range (blue), height * g'' (red)");
  const std::vector<double>& ranges = s.regrasp.ir_ranges;
  const RefineResult& refine = s.regrasp.refine;
  if (ranges.empty()) {
    Title(img, "(no IR refinement)", 1);
    return img;
  }
  const int n = static_cast<int>(ranges.size());
  auto plot = [&](const std::vector<double>& y, const cv::Scalar& c, int top, int bottom) {
    double lo = 1e9, hi = -1e9;
    for (double v : y)
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    if (!(hi > lo)) hi = lo + 1e-6;
    std::vector<cv::Point> pts;
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(y[i])) continue;
      pts.emplace_back(20 + (kW - 40) * i / std::max(1, n - 1), int(bottom - (bottom - top) * (y[i] - lo) / (hi - lo)));
    }
    cv::polylines(img, pts, false, c, 2, cv::LINE_AA);
    return std::pair<double, double>(lo, hi);
  };
  const auto [rlo, rhi] = plot(ranges, kBlue, 60, 250);
  plot(refine.response, kRed, 280, 450);
  const int x = 20 + (kW - 40) * refine.best / std::max(1, n - 1);
  cv::line(img, cv::Point(x, 50), cv::Point(x, 460), kGreen, 1);
  char buf[128];
  std::snprintf(buf, sizeof buf, "range %.3f..%.3f m; min at %+.1f cm", rlo, rhi, 100 * refine.offset);
  Title(img, buf, 1);
  return img;
}

void Save(const cv::Mat& img, const fs::path& path) {
  std::vector<uchar> buf;
  if (!cv::imencode(".png", img, buf)) throw Error(path.string() + ": PNG encoding failed");
  WriteFileAtomic(path, std::string(buf.begin(), buf.end()));
}

// One step: the reconstruction with the predicted and refined points, the kept
// registration coloured by the objective, the IR signal and its LoG response.
cv::Mat StepRow(const Step& s, double sensing_height) {
  cv::Mat row(kH, 3 * kW, CV_8UC3, kWhite);
  const TriMesh& recon = s.observe.recon;
  if (recon.NumFaces() > 0) {
    cv::Mat a = row(cv::Rect(0, 0, kW, kH));
    std::vector<Vec3> pts = Points(recon);
    const OrthoView v = Fit(pts);
    DrawShadedMesh(a, recon, v, kGrey);
    const Vec3 up(0, sensing_height, 0);  // world → holder frame (wrist at 0 after the turn)
    if (!s.plan.current_anchor.empty()) {
      Dot(a, v.Project(s.plan.predicted - up), kRed);
      Dot(a, v.Project(s.regrasp.grasp - up), kGreen, 4);
    }
    Title(a, "reconstruction (" + std::to_string(s.observe.frames) + " frames)");
    Title(a, "holding: " + s.truth.held_anchor + " (truth)", 1);
    Title(a, "next: predicted (red), refined (green)", 2);
    if (s.plan.registered.NumFaces() > 0) {
      const recognition::Recognition& r = s.recognise.recognition;
      cv::Mat b = row(cv::Rect(kW, 0, kW, kH));
      DrawScored(b, s.plan.registered, s.plan.point_score, v);
      Title(b, "matched " + r.best.id.substr(0, 40));
      Title(b, "recognised: " + r.category + " / " + r.anchor, 1);
      char buf[128];
      std::snprintf(buf, sizeof buf, "next %s, f = %.3f", s.plan.next_anchor.c_str(), s.plan.f);
      Title(b, buf, 2);
    }
  }
  IrPanel(s).copyTo(row(cv::Rect(2 * kW, 0, kW, kH)));
  return row;
}

// The end: the final grasps on the pattern beside the garment as it lies (placed) or hangs.
cv::Mat FinalRow(const TrialResult& t, const Garment& g) {
  cv::Mat fin(kH, 2 * kW, CV_8UC3, kWhite);
  std::vector<Mark> fm = DesiredMarks(g, t.category);
  for (const Vec2& u : t.final_uv) fm.push_back({u, kRed, ""});
  PatternPanel(g, fm, std::string(t.unfolded ? "unfolded" : "not unfolded") + ": grasps (red), desired (green)")
      .copyTo(fin(cv::Rect(0, 0, kW, kH)));
  if (t.final_mesh.NumFaces() == 0) return fin;
  cv::Mat b = fin(cv::Rect(kW, 0, kW, kH));
  if (t.placed) {
    // Seen from above as it lies on the table, fitted into the panel.
    const cv::Mat top = tabletop::TopDownPicture(t.final_mesh, tabletop::FrameCamera(t.final_mesh.V, 0.003), kGrey);
    const double s = std::min(double(kW) / top.cols, double(kH - 40) / top.rows);
    cv::Mat scaled;
    cv::resize(top, scaled, cv::Size(std::max(1, int(top.cols * s)), std::max(1, int(top.rows * s))), 0, 0,
               cv::INTER_AREA);
    scaled.copyTo(b(cv::Rect((kW - scaled.cols) / 2, 40, scaled.cols, scaled.rows)));
    char buf[96];
    std::snprintf(buf, sizeof buf, "laid on the table (top view), coverage %.2f", t.coverage);
    Title(b, buf);
  } else {
    DrawShadedMesh(b, t.final_mesh, Fit(Points(t.final_mesh)), kGrey);
    Title(b, "final state: " + t.final_state + (t.place_failure.empty() ? "" : " (" + t.place_failure + ")"));
  }
  return fin;
}
}  // namespace

std::vector<std::string> WriteTrialFigures(const TrialResult& t, const Garment& g, double sensing_height,
                                           const fs::path& dir) {
  fs::create_directories(dir);
  std::vector<std::string> files;
  std::vector<Mark> marks = DesiredMarks(g, t.category);
  marks.push_back({t.first_grasp_uv, kRed, "first grasp"});
  Save(PatternPanel(g, marks, "pick-up point (red), desired pair (green)"), dir / "pickup.png");
  files.push_back("pickup.png");
  for (size_t k = 0; k < t.steps.size(); ++k) {
    const std::string name = "step_" + std::to_string(k + 1) + ".png";
    Save(StepRow(t.steps[k], sensing_height), dir / name);
    files.push_back(name);
  }
  Save(FinalRow(t, g), dir / "final.png");
  files.push_back("final.png");
  return files;
}

}  // namespace drape::unfolding
