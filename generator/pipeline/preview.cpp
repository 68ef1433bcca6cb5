// preview.png: three panels side by side — the hung mesh with the anchor marked, a
// colour-mapped depth frame, the fused mesh — drawn with OpenCV (orthographic,
// object frame seen from +z, painter's algorithm). Deterministic pixels.
#include <algorithm>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "garments/render.h"
#include "generator/pipeline/build.h"

namespace drape {
namespace {

constexpr int kPanelW = 360, kPanelH = 440, kTitleH = 28;

OrthoView FitView(const TriMesh& mesh) {
  OrthoView v{kPanelW, kPanelH};
  if (mesh.NumVertices() == 0) {
    v.scale = 300;
    return v;
  }
  const auto b = Bounds(mesh);
  // Keep the grasp point (origin) in view too.
  Eigen::AlignedBox3d box = b;
  box.extend(Vec3::Zero());
  const Vec3 size = box.sizes();
  v.scale = 0.85 * std::min(kPanelW / std::max(size.x(), 1e-3), kPanelH / std::max(size.y(), 1e-3));
  v.cx = box.center().x();
  v.cy = box.center().y();
  return v;
}

void DrawMesh(cv::Mat& img, const TriMesh& mesh, const OrthoView& view, const cv::Scalar& base) {
  if (mesh.NumFaces() == 0) {
    cv::putText(img, "(empty)", {kPanelW / 2 - 40, kPanelH / 2}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {80, 80, 80}, 1,
                cv::LINE_AA);
    return;
  }
  DrawShadedMesh(img, mesh, view, base);
}

cv::Mat Panel(const std::string& label) {
  cv::Mat p(kPanelH, kPanelW, CV_8UC3, cv::Scalar(245, 245, 245));
  cv::putText(p, label, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {40, 40, 40}, 1, cv::LINE_AA);
  return p;
}

}  // namespace

std::string RenderEntryPreview(const TriMesh& hung, const Vec3& anchor_position, const std::string& depth_png,
                               const TriMesh& recon, const std::string& title) {
  const OrthoView view = FitView(hung);  // both meshes in the same frame and scale
  cv::Mat a = Panel("hung (anchor in red)");
  DrawMesh(a, hung, view, cv::Scalar(200, 150, 90));
  const cv::Point2d gp = view.Project(Vec3::Zero());
  const cv::Point2d ap = view.Project(anchor_position);
  cv::circle(a, {static_cast<int>(std::lround(ap.x)), static_cast<int>(std::lround(ap.y))}, 7, {0, 0, 220}, 2,
             cv::LINE_AA);
  cv::drawMarker(a, {static_cast<int>(std::lround(gp.x)), static_cast<int>(std::lround(gp.y))}, {0, 0, 0},
                 cv::MARKER_CROSS, 12, 1);

  cv::Mat b = Panel("depth frame");
  if (!depth_png.empty()) {
    std::vector<uchar> buf(depth_png.begin(), depth_png.end());
    cv::Mat d = cv::imdecode(buf, cv::IMREAD_COLOR);
    if (!d.empty()) {
      const double s = std::min((kPanelW - 8.0) / d.cols, (kPanelH - 36.0) / d.rows);
      cv::Mat r;
      cv::resize(d, r, cv::Size(std::max(1, int(d.cols * s)), std::max(1, int(d.rows * s))), 0, 0, cv::INTER_AREA);
      r.copyTo(b(cv::Rect((kPanelW - r.cols) / 2, 30, r.cols, r.rows)));
    }
  }

  cv::Mat c = Panel("fused (TSDF) mesh");
  DrawMesh(c, recon, view, cv::Scalar(120, 180, 120));

  cv::Mat row;
  cv::hconcat(std::vector<cv::Mat>{a, b, c}, row);
  cv::Mat out(row.rows + kTitleH, row.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  row.copyTo(out(cv::Rect(0, kTitleH, row.cols, row.rows)));
  cv::putText(out, title, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {0, 0, 0}, 1, cv::LINE_AA);
  std::vector<uchar> png;
  if (!cv::imencode(".png", out, png)) throw Error("preview: PNG encoding failed");
  return std::string(png.begin(), png.end());
}

}  // namespace drape
