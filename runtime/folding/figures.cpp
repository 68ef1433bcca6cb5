#include "runtime/folding/figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "garments/render.h"

namespace drape::folding {
namespace {

// The cloth seen from the front (+z towards the viewer, y up) tilted down by 50°.
cv::Mat Oblique(const Points3& x, const Faces& F, const Eigen::AlignedBox3d& box, int tile) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(50 * M_PI / 180, Vec3::UnitX()).toRotationMatrix();
  TriMesh m;
  m.F = F;
  m.V = (x * R.transpose()).eval();
  const Vec3 c = R * box.center();
  OrthoView v;
  v.width = v.height = tile;
  v.scale = 0.85 * tile / std::max(box.sizes().x(), box.sizes().z() * 1.2);
  v.cx = c.x();
  v.cy = c.y();
  cv::Mat img(tile, tile, CV_8UC3, cv::Scalar(255, 255, 255));
  DrawShadedMesh(img, m, v, cv::Scalar(200, 140, 60));
  return img;
}

// Outline of the mesh seen from above, drawn into img.
void Outline(cv::Mat& img, const Points3& x, const Faces& F, const tabletop::TopDownCamera& cam,
             const cv::Scalar& colour, int width) {
  const cv::Mat mask = tabletop::TopDownMask(TriMesh{x, F}, cam);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::drawContours(img, contours, -1, colour, width, cv::LINE_AA);
}

cv::Scalar Colour(double t) {
  cv::Mat one(1, 1, CV_8UC1, cv::Scalar(std::clamp(static_cast<int>(std::lround(255 * t)), 0, 255)));
  cv::Mat c;
  cv::applyColorMap(one, c, cv::COLORMAP_JET);
  const cv::Vec3b b = c.at<cv::Vec3b>(0, 0);
  return cv::Scalar(b[0], b[1], b[2]);
}

}  // namespace

cv::Mat StepKeyFrames(const StepRecord& step, const Faces& F, int tile) {
  const StepSim& s = step.result.after;
  Eigen::AlignedBox3d box;
  for (int i = 0; i < step.setup.start.rows(); ++i) box.extend(Vec3(step.setup.start.row(i).transpose()));
  box.extend(box.max() + Vec3(0, 0.3 * box.sizes().x(), 0));
  std::vector<cv::Mat> tiles;
  for (const Points3& f : s.frames) tiles.push_back(Oblique(f, F, box, tile));
  // Result (light blue) against target (black), from above.
  tabletop::TopDownCamera cam = tabletop::FrameCamera(step.setup.start, 1.0, 0.05);
  const double extent = std::max(cam.width, cam.height) * 1.0;
  cam.metres_per_pixel = extent / (tile - 10);
  cam.width = cam.height = tile;
  cv::Mat top(tile, tile, CV_8UC3, cv::Scalar(255, 255, 255));
  Outline(top, step.setup.target.V, F, cam, cv::Scalar(0, 0, 0), 2);
  if (s.ok) Outline(top, s.final, F, cam, cv::Scalar(230, 180, 90), 2);
  char buf[64];
  std::snprintf(buf, sizeof buf, "D = %.1f mm", 1e3 * s.dissimilarity);
  cv::putText(top, buf, cv::Point(6, tile - 8), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  tiles.push_back(top);
  cv::Mat row;
  cv::hconcat(tiles, row);
  cv::putText(row, step.name, cv::Point(6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return row;
}

cv::Mat FlatGarmentFigure(const PlanRun& run, const Faces& F, const std::string& caption) {
  if (run.flat.rows() == 0) throw Error("FlatGarmentFigure: the run has no settled flat garment");
  const tabletop::TopDownCamera& cam = run.camera;
  cv::Mat img = tabletop::TopDownPicture(TriMesh{run.flat, F}, cam, cv::Scalar(200, 140, 60));
  Outline(img, run.flat, F, cam, cv::Scalar(0, 0, 0), 1);
  for (const auto& [name, xz] : run.key_points) {
    const Vec2 f = cam.ToFrame(xz.x(), xz.y());
    const cv::Point p(static_cast<int>(f.x()), static_cast<int>(-f.y()));
    cv::circle(img, p, 4, cv::Scalar(0, 0, 255), -1, cv::LINE_AA);
    cv::putText(img, name, p + cv::Point(5, -5), cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 160), 1, cv::LINE_AA);
  }
  cv::Mat out;
  cv::copyMakeBorder(img, out, 24, 0, 0, 0, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
  cv::putText(out, caption, cv::Point(4, 16), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return out;
}

cv::Mat ResultFigure(const PlanRun& run, const Faces& F, double tolerance, const std::string& caption) {
  if (run.final.rows() == 0) throw Error("ResultFigure: the run has no final shape");
  Points3 both(run.final.rows() + run.ideal.V.rows(), 3);
  both << run.final, run.ideal.V;
  const double mpp = 0.002;
  const tabletop::TopDownCamera cam = tabletop::FrameCamera(both, mpp, tolerance + 0.03);
  cv::Mat img = tabletop::TopDownPicture(TriMesh{run.final, F}, cam, cv::Scalar(200, 140, 60));
  cv::Mat grown;
  const int r = static_cast<int>(std::ceil(tolerance / mpp));
  cv::dilate(tabletop::TopDownMask(run.ideal, cam), grown,
             cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(grown, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::drawContours(img, contours, -1, cv::Scalar(150, 150, 150), 1, cv::LINE_AA);
  Outline(img, run.ideal.V, F, cam, cv::Scalar(0, 0, 0), 2);
  cv::Mat out;
  // Wide enough for the caption.
  const int right = std::max(0, 7 * static_cast<int>(caption.size()) + 8 - img.cols);
  cv::copyMakeBorder(img, out, 24, 0, 0, right, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
  cv::putText(out, caption, cv::Point(4, 16), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return out;
}

std::vector<FanTrajectory> SolutionFan(const FoldScene& scene, const StepSetup& setup, const FoldSimOptions& sim,
                                       const std::string& kind, int count) {
  if (kind != "symmetric" && kind != "early" && kind != "late")
    throw Error("fan kind must be symmetric, early or late");
  std::vector<FanTrajectory> out;
  for (int k = 0; k < count; ++k) {
    const double h = 0.05 + 0.9 * k / std::max(1, count - 1);
    std::vector<CubicBezier> paths;
    for (size_t a = 0; a < setup.p0.size(); ++a) {
      CubicBezier c = InitialTrajectory(setup.p0[a], setup.p3[a], 1.0 / 3);
      const double s = (setup.p0[a] - setup.p3[a]).norm();
      const Vec3 base1 = (2 * setup.p0[a] + setup.p3[a]) / 3, base2 = (setup.p0[a] + 2 * setup.p3[a]) / 3;
      if (kind != "late") c.P[1] = base1 + h * s * Vec3::UnitY();
      if (kind != "early") c.P[2] = base2 + h * s * Vec3::UnitY();
      paths.push_back(c);
    }
    const StepSim r = SimulateStep(scene, setup, paths, sim);
    out.push_back({paths[0], h, r.ok ? r.dissimilarity : std::numeric_limits<double>::quiet_NaN()});
  }
  return out;
}

cv::Mat FanFigure(const std::vector<std::vector<FanTrajectory>>& fans, const std::vector<std::string>& titles) {
  DRAPE_CHECK(fans.size() == titles.size() && !fans.empty(), "one title per fan");
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& fan : fans)
    for (const auto& t : fan)
      if (std::isfinite(t.dissimilarity)) lo = std::min(lo, t.dissimilarity), hi = std::max(hi, t.dissimilarity);
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (hi <= lo) hi = lo + 1e-6;
  const int W = 360, H = 300, bar = 90;
  std::vector<cv::Mat> panels;
  for (size_t f = 0; f < fans.size(); ++f) {
    cv::Mat p(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
    const auto& fan = fans[f];
    // Plane coordinates: distance along P0→P3 (horizontal part) and height above P0.
    const Vec3 p0 = fan.front().path.P[0], p3 = fan.front().path.P[3];
    Vec3 u = p3 - p0;
    u.y() = 0;
    const double span = u.norm();
    u.normalize();
    const double scale = (W - 60) / span;
    auto px = [&](const Vec3& q) {
      const Vec3 d = q - p0;
      return cv::Point(30 + static_cast<int>(std::lround(d.dot(u) * scale)),
                       H - 40 - static_cast<int>(std::lround(d.y() * scale)));
    };
    for (const auto& t : fan) {
      std::vector<cv::Point> line;
      for (int k = 0; k <= 60; ++k) line.push_back(px(t.path.Eval(k / 60.0)));
      const cv::Scalar c =
          std::isfinite(t.dissimilarity) ? Colour((t.dissimilarity - lo) / (hi - lo)) : cv::Scalar(128, 128, 128);
      cv::polylines(p, line, false, c, 2, cv::LINE_AA);
    }
    cv::line(p, cv::Point(0, px(p0).y), cv::Point(W, px(p0).y), cv::Scalar(160, 160, 160), 1);
    cv::putText(p, "S", px(p0) + cv::Point(-6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 2);
    cv::putText(p, "T", px(p3) + cv::Point(-6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 2);
    cv::putText(p, titles[f], cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    panels.push_back(p);
  }
  // Colour bar: D from lo (bottom) to hi (top), millimetres.
  cv::Mat b(H, bar, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int y = 30; y < H - 40; ++y)
    cv::line(b, cv::Point(10, y), cv::Point(30, y), Colour(1.0 - (y - 30.0) / (H - 70.0)), 1);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", 1e3 * hi);
  cv::putText(b, buf, cv::Point(34, 36), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  std::snprintf(buf, sizeof buf, "%.1f", 1e3 * lo);
  cv::putText(b, buf, cv::Point(34, H - 40), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  cv::putText(b, "D (mm)", cv::Point(10, 20), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  panels.push_back(b);
  cv::Mat out;
  cv::hconcat(panels, out);
  return out;
}

}  // namespace drape::folding
