#include "garments/preview.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/error.h"

namespace drape {
namespace {

const cv::Scalar kFill(235, 215, 185), kWire(190, 170, 140), kSeam(60, 50, 40), kOpening(40, 40, 220);
const cv::Scalar kLeft(200, 90, 30), kRight(40, 150, 40), kCentre(20, 120, 230), kText(20, 20, 20);

cv::Scalar AnchorColour(const std::string& label) {
  if (label.rfind("left", 0) == 0 || label.find("_left") != std::string::npos) return kLeft;
  if (label.rfind("right", 0) == 0 || label.find("_right") != std::string::npos) return kRight;
  return kCentre;
}

// A "nice" scale bar length close to a fifth of the garment width.
double NiceLength(double extent) {
  const double target = extent / 5;
  double best = 0.01;
  for (double v : {0.01, 0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0})
    if (v <= target) best = v;
  return best;
}

// Where the flat preview draws a vertex: its pattern (uv) position, or x–y without uv,
// scaled into the image; OpenCV's sub-pixel points shift by kShift bits.
struct FlatView {
  static constexpr int kShift = 4;
  const Garment* g = nullptr;
  bool have_uv = false;
  Eigen::AlignedBox2d box;
  double scale = 1;  // px per metre
  int x0 = 0, y0 = 0;
  Vec2 Pos(int v) const { return have_uv ? Vec2(g->uv.row(v)) : Vec2(g->mesh.V(v, 0), g->mesh.V(v, 1)); }
  cv::Point2d Px(const Vec2& p) const {
    return cv::Point2d(x0 + (p.x() - box.min().x()) * scale, y0 + (box.max().y() - p.y()) * scale);
  }
  cv::Point Fixed(int v) const {
    const cv::Point2d p = Px(Pos(v));
    return cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))),
                     static_cast<int>(std::lround(p.y * (1 << kShift))));
  }
};

// The faces seen from the front: layer 0, else counter-clockwise on the pattern, else
// facing +z; all faces if none is.
std::vector<int> FrontFaces(const Garment& g, const FlatView& view) {
  const TriMesh& m = g.mesh;
  const bool have_layer = static_cast<int>(g.layer.size()) == m.NumVertices();
  std::vector<int> front;
  const Points3 normals = FaceNormals(m);
  for (int f = 0; f < m.NumFaces(); ++f) {
    bool is_front = true;
    if (have_layer) {
      for (int k = 0; k < 3; ++k) is_front &= g.layer[m.F(f, k)] == 0;
    } else if (view.have_uv) {
      // Front faces run counter-clockwise on the pattern, back faces clockwise; this
      // holds however the garment is draped in 3D.
      const Vec2 p0 = view.Pos(m.F(f, 0)), p1 = view.Pos(m.F(f, 1)), p2 = view.Pos(m.F(f, 2));
      is_front = (p1 - p0).x() * (p2 - p0).y() - (p1 - p0).y() * (p2 - p0).x() > 0;
    } else {
      is_front = normals(f, 2) >= 0;
    }
    if (is_front) front.push_back(f);
  }
  if (front.empty())
    for (int f = 0; f < m.NumFaces(); ++f) front.push_back(f);
  return front;
}

// The front faces filled, their inner edges as a wire, seams and openings (edges of one
// front face: an opening when the whole mesh uses it once) drawn thicker.
void DrawFaces(cv::Mat& img, const TriMesh& m, const std::vector<int>& front, const FlatView& view) {
  for (int f : front) {
    cv::Point tri[3];
    for (int k = 0; k < 3; ++k) tri[k] = view.Fixed(m.F(f, k));
    cv::fillConvexPoly(img, tri, 3, kFill, cv::LINE_AA, FlatView::kShift);
  }
  // Edge use counts: in the front set and in the whole mesh.
  std::map<std::pair<int, int>, int> front_count, all_count;
  for (int f = 0; f < m.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.F(f, k), b = m.F(f, (k + 1) % 3);
      ++all_count[{std::min(a, b), std::max(a, b)}];
    }
  for (int f : front)
    for (int k = 0; k < 3; ++k) {
      const int a = m.F(f, k), b = m.F(f, (k + 1) % 3);
      ++front_count[{std::min(a, b), std::max(a, b)}];
    }
  for (const auto& [e, c] : front_count)
    if (c > 1) cv::line(img, view.Fixed(e.first), view.Fixed(e.second), kWire, 1, cv::LINE_AA, FlatView::kShift);
  for (const auto& [e, c] : front_count) {
    if (c != 1) continue;
    const bool opening = all_count[e] == 1;  // a hole in the whole mesh, not a seam
    cv::line(img, view.Fixed(e.first), view.Fixed(e.second), opening ? kOpening : kSeam, opening ? 3 : 2, cv::LINE_AA,
             FlatView::kShift);
  }
}

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// A label box w×h (+base) near dot d that overlaps nothing in `taken` and stays in the
// image; the outward side first (labels on the left half go left).
cv::Rect PlaceLabel(const cv::Point& d, int w, int h, int base, const std::vector<cv::Rect>& taken, int width,
                    int height) {
  const bool left_half = d.x < width / 2;
  std::vector<cv::Point> offsets;
  for (int r : {10, 22, 36}) {
    const cv::Point out = left_half ? cv::Point(-w - r, h / 2) : cv::Point(r, h / 2);
    const cv::Point in = left_half ? cv::Point(r, h / 2) : cv::Point(-w - r, h / 2);
    offsets.insert(offsets.end(), {out, cv::Point(-w / 2, -r), cv::Point(-w / 2, h + r), in, out + cv::Point(0, -r),
                                   out + cv::Point(0, r)});
  }
  for (const cv::Point& o : offsets) {
    const cv::Rect r(d.x + o.x - 2, d.y + o.y - h - 2, w + 4, h + base + 4);
    if (r.x < 0 || r.y < 0 || r.x + r.width > width || r.y + r.height > height) continue;
    bool clash = false;
    for (const cv::Rect& t : taken) clash |= (r & t).area() > 0;
    if (!clash) return r;
  }
  const cv::Point o = offsets.front();
  return cv::Rect(std::clamp(d.x + o.x - 2, 0, std::max(0, width - w - 4)),
                  std::clamp(d.y + o.y - h - 2, 0, std::max(0, height - h - base - 4)), w + 4, h + base + 4);
}

// Anchors: dots, then labels placed greedily where they overlap nothing placed yet.
void DrawAnchors(cv::Mat& img, const Garment& g, const FlatView& view) {
  const int nv = g.mesh.NumVertices();
  const double fs = 0.42;
  std::vector<cv::Rect> taken;
  std::vector<cv::Point> dots;
  for (const Anchor& a : g.anchors) {
    if (a.vertex < 0 || a.vertex >= nv) continue;
    dots.push_back(view.Px(view.Pos(a.vertex)));
  }
  taken.reserve(taken.size() + dots.size());
  for (const cv::Point& d : dots) taken.emplace_back(d.x - 6, d.y - 6, 12, 12);
  size_t di = 0;
  for (const Anchor& a : g.anchors) {
    if (a.vertex < 0 || a.vertex >= nv) continue;
    const cv::Point d = dots[di++];
    cv::circle(img, d, 6, cv::Scalar(255, 255, 255), cv::FILLED, cv::LINE_AA);
    cv::circle(img, d, 5, AnchorColour(a.label), cv::FILLED, cv::LINE_AA);
    cv::circle(img, d, 6, kText, 1, cv::LINE_AA);
    int base = 0;
    const cv::Size ts = cv::getTextSize(a.label, kFont, fs, 1, &base);
    const int h = ts.height;
    const cv::Rect chosen = PlaceLabel(d, ts.width, h, base, taken, img.cols, img.rows);
    taken.push_back(chosen);
    // Leader line from the dot to the label, then the label on a white box.
    cv::line(img, d,
             cv::Point(std::clamp(d.x, chosen.x, chosen.x + chosen.width),
                       std::clamp(d.y, chosen.y, chosen.y + chosen.height)),
             cv::Scalar(120, 120, 120), 1, cv::LINE_AA);
    cv::rectangle(img, chosen, cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(img, chosen, AnchorColour(a.label), 1);
    cv::putText(img, a.label, cv::Point(chosen.x + 2, chosen.y + 2 + h), kFont, fs, kText, 1, cv::LINE_AA);
  }
}

// Title (instance, category, counts), the caption and a scale bar with the garment's size.
void DrawTitleAndScale(cv::Mat& img, const Garment& g, const Vec2& ext, double scale) {
  std::ostringstream title;
  title << (g.instance.empty() ? g.category : g.instance) << "  (" << g.category << ")  V=" << g.mesh.NumVertices()
        << " F=" << g.mesh.NumFaces() << " anchors=" << g.anchors.size();
  cv::putText(img, title.str(), cv::Point(12, 28), kFont, 0.6, kText, 1, cv::LINE_AA);
  const char* caption = g.category == "towel" ? "front view: left/right as in this picture; red = openings"
                                              : "front view: wearer's left = image right; red = openings";
  cv::putText(img, caption, cv::Point(12, 46), kFont, 0.4, cv::Scalar(90, 90, 90), 1, cv::LINE_AA);
  const double bar = NiceLength(ext.x());
  const int bx = 20, by = img.rows - 25, bl = static_cast<int>(std::lround(bar * scale));
  cv::rectangle(img, cv::Point(bx, by - 4), cv::Point(bx + bl, by + 4), kText, cv::FILLED);
  std::ostringstream bt;
  if (bar < 1)
    bt << std::lround(bar * 100) << " cm";
  else
    bt << bar << " m";
  std::ostringstream size;
  size << "  (garment " << std::lround(ext.x() * 100) << " x " << std::lround(ext.y() * 100) << " cm)";
  cv::putText(img, bt.str() + size.str(), cv::Point(bx + bl + 10, by + 5), kFont, 0.5, kText, 1, cv::LINE_AA);
}

}  // namespace

std::string RenderFlatPreview(const Garment& g, int width_px) {
  if (width_px < 200 || width_px > 8000) throw Error("preview width must be in [200, 8000] px");
  const TriMesh& m = g.mesh;
  if (m.NumVertices() == 0 || m.NumFaces() == 0) throw Error("preview: garment '" + g.instance + "' has no triangles");
  FlatView view;
  view.g = &g;
  view.have_uv = g.uv.rows() == m.NumVertices();
  const std::vector<int> front = FrontFaces(g, view);

  for (int f : front)
    for (int k = 0; k < 3; ++k) view.box.extend(view.Pos(m.F(f, k)));
  const Vec2 ext = (view.box.max() - view.box.min()).cwiseMax(1e-6);
  const int margin = 70, top = 50, bottom = 60;
  view.scale = (width_px - 2.0 * margin) / std::max(ext.x(), ext.y() * 0.5);
  const int draw_w = static_cast<int>(std::ceil(ext.x() * view.scale));
  const int height = std::min(4 * width_px, static_cast<int>(std::ceil(ext.y() * view.scale)) + top + bottom + margin);
  view.x0 = (width_px - draw_w) / 2;
  view.y0 = top + margin / 2;

  cv::Mat img(height, width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  DrawFaces(img, m, front, view);
  DrawAnchors(img, g, view);
  DrawTitleAndScale(img, g, ext, view.scale);

  std::vector<uchar> png;
  if (!cv::imencode(".png", img, png)) throw Error("preview: PNG encoding failed");
  return std::string(png.begin(), png.end());
}

}  // namespace drape
