#include "runtime/folding/keypoints.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "common/error.h"

namespace drape::folding {
namespace {

struct Defect {
  Vec2 start, end, far;
  double depth = 0;            // pixels
  int i_start = 0, i_end = 0;  // contour indices of start and end (the notch between)
};

// Contour points in the y-up frame.
struct Outline {
  std::vector<Vec2> pts;
  std::vector<Defect> defects;               // sorted deepest first
  double min_depth = 0, min_neck_depth = 0;  // pixels: KeyPointOptions' fractions of the width
  std::vector<Vec2> poly;                    // the outline simplified to its corners (approxPolyDP)
  Vec2 centroid = Vec2::Zero();
  double width = 0, height = 0;
};

Vec2 ToFrame(const cv::Point& p) { return Vec2(p.x + 0.5, -(p.y + 0.5)); }

Outline Analyse(const cv::Mat& mask, double min_defect_depth, double min_neck_depth, double corner_tolerance) {
  if (mask.empty() || mask.type() != CV_8UC1) throw Error("key points: the mask must be a non-empty 8-bit image");
  cv::Mat bin = mask != 0;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bin, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) throw Error("key points: the mask has no garment pixels");
  const auto& c = *std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
    return cv::contourArea(a) < cv::contourArea(b);
  });
  if (c.size() < 8) throw Error("key points: the garment blob is too small");
  Outline o;
  for (const auto& p : c) o.pts.push_back(ToFrame(p));
  const cv::Moments m = cv::moments(c);
  o.centroid = Vec2(m.m10 / m.m00 + 0.5, -(m.m01 / m.m00 + 0.5));
  const cv::Rect box = cv::boundingRect(c);
  o.width = box.width;
  o.height = box.height;
  std::vector<cv::Point> simple;
  cv::approxPolyDP(c, simple, corner_tolerance * o.width, true);
  for (const auto& p : simple) o.poly.push_back(ToFrame(p));
  std::vector<int> hull;
  cv::convexHull(c, hull, false, false);
  std::vector<cv::Vec4i> defects;
  if (hull.size() > 3) cv::convexityDefects(c, hull, defects);
  for (const auto& d : defects) {
    const double depth = d[3] / 256.0;
    if (depth < std::min(min_defect_depth, min_neck_depth) * o.width) continue;
    o.defects.push_back({ToFrame(c[d[0]]), ToFrame(c[d[1]]), ToFrame(c[d[2]]), depth, d[0], d[1]});
  }
  std::sort(o.defects.begin(), o.defects.end(), [](const Defect& a, const Defect& b) { return a.depth > b.depth; });
  o.min_depth = min_defect_depth * o.width;
  o.min_neck_depth = min_neck_depth * o.width;
  return o;
}

// The point of `pts` passing `keep` that is furthest along `dir`.
Vec2 Extreme(const std::vector<Vec2>& pts, const Vec2& dir, const std::function<bool(const Vec2&)>& keep,
             const char* what) {
  double best = -std::numeric_limits<double>::infinity();
  Vec2 arg = Vec2::Zero();
  for (const Vec2& p : pts)
    if (keep(p) && p.dot(dir) > best) best = p.dot(dir), arg = p;
  if (!std::isfinite(best)) throw Error(std::string("key points: found no contour point for ") + what);
  return arg;
}

// Deepest defect passing `keep` and at least min_depth deep (default: Outline::min_depth).
const Defect& DeepestWhere(const Outline& o, const std::function<bool(const Defect&)>& keep, const char* what,
                           double min_depth = -1) {
  if (min_depth < 0) min_depth = o.min_depth;
  for (const Defect& d : o.defects)
    if (d.depth >= min_depth && keep(d)) return d;
  throw Error(std::string("key points: no convexity defect found for ") + what);
}

// The bottom of a notch: the middle of the contour points within 1.5 px of the defect's
// depth from its hull edge (a notch with a flat bottom has no single deepest pixel).
Vec2 NotchBottom(const Outline& o, const Defect& d) {
  const Vec2 e = (d.end - d.start).normalized();
  const Vec2 n(-e.y(), e.x());
  const int m = static_cast<int>(o.pts.size());
  Vec2 sum = Vec2::Zero();
  int count = 0;
  // The contour between the defect's hull points, in contour order.
  for (int i = d.i_start; i != d.i_end; i = (i + 1) % m) {
    const Vec2& p = o.pts[i];
    if (std::abs((p - d.start).dot(n)) >= d.depth - 1.5) sum += p, ++count;
  }
  return count ? Vec2(sum / count) : d.far;
}

using Points = std::map<std::string, Vec2>;

void Towel(const Outline& o, Points& k) {
  auto all = [](const Vec2&) { return true; };
  k["top_left"] = Extreme(o.pts, Vec2(-1, 1), all, "top_left");
  k["top_right"] = Extreme(o.pts, Vec2(1, 1), all, "top_right");
  k["bottom_left"] = Extreme(o.pts, Vec2(-1, -1), all, "bottom_left");
  k["bottom_right"] = Extreme(o.pts, Vec2(1, -1), all, "bottom_right");
}

void Legs(const Outline& o, Points& k) {
  // The crotch is the deepest notch opening downwards (its hull edge spans the legs'
  // openings, below it).
  const Vec2 crotch =
      NotchBottom(o, DeepestWhere(
                         o, [&](const Defect& d) { return d.far.y() > std::max(d.start.y(), d.end.y()); },
                         "the crotch (between the legs)"));
  k["crotch"] = crotch;
  auto above = [&](const Vec2& p) { return p.y() > crotch.y(); };
  k["left_waist"] = Extreme(o.pts, Vec2(1, 1), above, "left_waist");
  k["right_waist"] = Extreme(o.pts, Vec2(-1, 1), above, "right_waist");
  k["waist_center"] = 0.5 * (k["left_waist"] + k["right_waist"]);
  // The wearer's left leg is on the picture's right.
  auto left_leg = [&](const Vec2& p) { return p.x() > crotch.x() && p.y() < crotch.y(); };
  auto right_leg = [&](const Vec2& p) { return p.x() < crotch.x() && p.y() < crotch.y(); };
  k["left_leg_outer"] = Extreme(o.pts, Vec2(1, -1), left_leg, "left_leg_outer");
  k["left_leg_inner"] = Extreme(o.pts, Vec2(-1, -1), left_leg, "left_leg_inner");
  k["right_leg_outer"] = Extreme(o.pts, Vec2(-1, -1), right_leg, "right_leg_outer");
  k["right_leg_inner"] = Extreme(o.pts, Vec2(1, -1), right_leg, "right_leg_inner");
}

void Shirt(const Outline& o, Points& k, bool long_sleeve) {
  const double W = o.width, cx = o.centroid.x();
  const std::string l_end = long_sleeve ? "left_cuff" : "left_sleeve_end";
  const std::string r_end = long_sleeve ? "right_cuff" : "right_sleeve_end";
  // The neckline is the deepest notch near the top centre that opens upwards (its hull
  // edge, between the neck points, above its bottom). Without the last condition an
  // armpit notch (it opens downwards: its hull edge runs from the cuff down to the hem)
  // that lies within W/6 of the centroid — a shirt turned by a few degrees — was taken
  // for the collar, and that armpit was then missing.
  const Defect& neck = DeepestWhere(
      o,
      [&](const Defect& d) {
        return d.far.y() > o.centroid.y() && std::abs(d.far.x() - cx) < W / 6 &&
               d.far.y() < std::min(d.start.y(), d.end.y());
      },
      "the collar", o.min_neck_depth);
  k["collar"] = NotchBottom(o, neck);
  k["left_neck"] = neck.start.x() > neck.end.x() ? neck.start : neck.end;
  k["right_neck"] = neck.start.x() > neck.end.x() ? neck.end : neck.start;
  // Armpits: the deepest notch on each side, between sleeve and body.
  auto side = [&](double s) {
    return [&, s](const Defect& d) { return s * (d.far.x() - cx) > W / 10 && &d != &neck; };
  };
  k["left_armpit"] = DeepestWhere(o, side(1), "left_armpit").far;
  k["right_armpit"] = DeepestWhere(o, side(-1), "right_armpit").far;
  const Vec2 la = k["left_armpit"], ra = k["right_armpit"];
  // Sleeve ends: on the outline's corners, the outermost corner is the opening's upper
  // end and the lower of its two neighbours the opening's lower end (sleeves point
  // down-outwards); the sleeve end is the middle of that edge.
  auto sleeve_end = [&](double s) {
    const int n = static_cast<int>(o.poly.size());
    int tip = 0;
    for (int i = 1; i < n; ++i)
      if (s * o.poly[i].x() > s * o.poly[tip].x()) tip = i;
    const Vec2& a = o.poly[(tip + n - 1) % n];
    const Vec2& b = o.poly[(tip + 1) % n];
    return Vec2(0.5 * (o.poly[tip] + (a.y() < b.y() ? a : b)));
  };
  k[l_end] = sleeve_end(1);
  k[r_end] = sleeve_end(-1);
  const double slack = 0.02 * W;
  k["left_hem"] = Extreme(
      o.pts, Vec2(1, -1), [&](const Vec2& p) { return p.y() < la.y() && p.x() < la.x() + slack; }, "left_hem");
  k["right_hem"] = Extreme(
      o.pts, Vec2(-1, -1), [&](const Vec2& p) { return p.y() < ra.y() && p.x() > ra.x() - slack; }, "right_hem");
  k["hem_center"] = 0.5 * (k["left_hem"] + k["right_hem"]);
  // Shoulders: the top of the outline straight above each armpit.
  k["left_shoulder"] = Extreme(
      o.pts, Vec2(0, 1), [&](const Vec2& p) { return p.y() > la.y() && std::abs(p.x() - la.x()) <= slack; },
      "left_shoulder");
  k["right_shoulder"] = Extreme(
      o.pts, Vec2(0, 1), [&](const Vec2& p) { return p.y() > ra.y() && std::abs(p.x() - ra.x()) <= slack; },
      "right_shoulder");
}

}  // namespace

const std::vector<std::string>& KeyPointNames(const std::string& category) {
  static const std::map<std::string, std::vector<std::string>> names = {
      {"towel", {"center", "top_left", "top_right", "bottom_left", "bottom_right"}},
      {"pants",
       {"center", "crotch", "left_waist", "right_waist", "waist_center", "left_leg_outer", "left_leg_inner",
        "right_leg_outer", "right_leg_inner"}},
      {"long_sleeve_shirt",
       {"center", "left_cuff", "right_cuff", "collar", "left_neck", "right_neck", "left_armpit", "right_armpit",
        "left_hem", "right_hem", "hem_center", "left_shoulder", "right_shoulder"}},
      {"tshirt",
       {"center", "left_sleeve_end", "right_sleeve_end", "collar", "left_neck", "right_neck", "left_armpit",
        "right_armpit", "left_hem", "right_hem", "hem_center", "left_shoulder", "right_shoulder"}},
  };
  static const std::vector<std::string> none;
  const std::string key = category == "shorts" ? "pants" : category;
  auto it = names.find(key);
  return it == names.end() ? none : it->second;
}

void KeyPointOptions::Validate() const {
  if (!(corner_tolerance > 0 && corner_tolerance < 0.2))
    throw Error("KeyPointOptions.corner_tolerance must be in (0, 0.2)");
  if (!(min_defect_depth >= 0 && min_defect_depth < 0.5))
    throw Error("KeyPointOptions.min_defect_depth must be in [0, 0.5)");
  if (!(min_neck_depth >= 0 && min_neck_depth < 0.5)) throw Error("KeyPointOptions.min_neck_depth must be in [0, 0.5)");
}

std::map<std::string, Vec2> DetectKeyPoints(const cv::Mat& mask, const std::string& category,
                                            const KeyPointOptions& options) {
  options.Validate();
  if (KeyPointNames(category).empty())
    throw Error("key points: no detector for category '" + category +
                "' (known: towel, pants, shorts, long_sleeve_shirt, tshirt)");
  const Outline o = Analyse(mask, options.min_defect_depth, options.min_neck_depth, options.corner_tolerance);
  Points k;
  k["center"] = o.centroid;
  if (category == "towel")
    Towel(o, k);
  else if (category == "pants" || category == "shorts")
    Legs(o, k);
  else
    Shirt(o, k, category == "long_sleeve_shirt");
  return k;
}

}  // namespace drape::folding
