// Key points on synthetic top-down masks: each garment template's outline filled into
// a mask, the detected key points against the template's own labelled anchors
// (garments/anchors.md), and a rotated rectangle for the towel corners.
#include "runtime/folding/keypoints.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "garments/templates.h"

namespace drape::folding {
namespace {

constexpr double kMpp = 0.0025;  // metres per pixel
constexpr int kMargin = 20;      // pixels

struct Picture {
  cv::Mat mask;
  double xmin = 0, ymax = 0;
  // Pattern coordinates (metres, y up) of a key point in the mask frame.
  Vec2 ToPattern(const Vec2& k) const { return Vec2(xmin + (k.x() - kMargin) * kMpp, ymax + (k.y() + kMargin) * kMpp); }
};

Picture Fill(const std::vector<Vec2>& poly) {
  Picture p;
  double xmax = -1e9, ymin = 1e9;
  p.xmin = 1e9, p.ymax = -1e9;
  for (const Vec2& v : poly) {
    p.xmin = std::min(p.xmin, v.x()), xmax = std::max(xmax, v.x());
    ymin = std::min(ymin, v.y()), p.ymax = std::max(p.ymax, v.y());
  }
  const int w = static_cast<int>((xmax - p.xmin) / kMpp) + 2 * kMargin;
  const int h = static_cast<int>((p.ymax - ymin) / kMpp) + 2 * kMargin;
  p.mask = cv::Mat::zeros(h, w, CV_8UC1);
  // Sub-pixel vertices (4 fractional bits): pixel centres sit at integer coordinates.
  std::vector<cv::Point> pts;
  for (const Vec2& v : poly) {
    const double col = (v.x() - p.xmin) / kMpp + kMargin - 0.5, row = (p.ymax - v.y()) / kMpp + kMargin - 0.5;
    pts.emplace_back(static_cast<int>(std::lround(col * 16)), static_cast<int>(std::lround(row * 16)));
  }
  cv::fillPoly(p.mask, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_8, 4);
  return p;
}

// Detected key points vs the template's anchors of the same names, within tol metres;
// the outline and the anchors turned by `turn` radians about the origin (a garment
// laid a few degrees off, as the folding trials place it).
void CheckTemplate(const std::string& name, const std::map<std::string, double>& tolerance, double turn = 0) {
  TemplateShape shape = MakeTemplateShape(name, TemplateOptions{});
  const Eigen::Rotation2Dd R(turn);
  for (Vec2& p : shape.contour.points) p = R * p;
  for (auto& a : shape.anchors) a.uv = R * a.uv;
  const Picture pic = Fill(shape.contour.points);
  const auto k = DetectKeyPoints(pic.mask, shape.name == "shorts" ? "shorts" : name);
  for (const auto& n : KeyPointNames(name)) EXPECT_TRUE(k.count(n)) << name << " lacks " << n;
  for (const auto& [label, tol] : tolerance) {
    const AnchorSpec* a = nullptr;
    for (const auto& s : shape.anchors)
      if (s.label == label) a = &s;
    ASSERT_NE(a, nullptr) << name << " template has no anchor " << label;
    ASSERT_TRUE(k.count(label)) << label;
    const double err = (pic.ToPattern(k.at(label)) - a->uv).norm();
    const Vec2 got = pic.ToPattern(k.at(label));
    std::printf("%s %-16s error %.1f mm (found %.3f %.3f, anchor %.3f %.3f)\n", name.c_str(), label.c_str(), err * 1e3,
                got.x(), got.y(), a->uv.x(), a->uv.y());
    EXPECT_LT(err, tol) << name << " " << label;
  }
}

TEST(KeyPoints, TowelCornersOnTheTemplate) {
  CheckTemplate("towel", {{"top_left", 0.01}, {"top_right", 0.01}, {"bottom_left", 0.01}, {"bottom_right", 0.01}});
}

TEST(KeyPoints, PantsWaistCrotchAndLegCorners) {
  // The crotch is a sharp notch: where its sides come closer than a pixel the mask
  // fills it, so the found apex sits up to ~1.5 cm low at 2.5 mm per pixel.
  CheckTemplate("pants", {{"left_waist", 0.01},
                          {"right_waist", 0.01},
                          {"waist_center", 0.01},
                          {"crotch", 0.02},
                          {"left_leg_outer", 0.01},
                          {"left_leg_inner", 0.01},
                          {"right_leg_outer", 0.01},
                          {"right_leg_inner", 0.01}});
}

TEST(KeyPoints, ShortsLikePants) {
  CheckTemplate("shorts", {{"left_waist", 0.01},
                           {"right_waist", 0.01},
                           {"crotch", 0.02},
                           {"left_leg_outer", 0.01},
                           {"left_leg_inner", 0.01},
                           {"right_leg_outer", 0.01},
                           {"right_leg_inner", 0.01}});
}

TEST(KeyPoints, LongSleeveShirtCuffsCollarArmpitsHem) {
  CheckTemplate("long_sleeve_shirt", {{"left_cuff", 0.02},
                                      {"right_cuff", 0.02},
                                      {"collar", 0.01},
                                      {"left_neck", 0.01},
                                      {"right_neck", 0.01},
                                      {"left_armpit", 0.01},
                                      {"right_armpit", 0.01},
                                      {"left_hem", 0.01},
                                      {"right_hem", 0.01},
                                      {"hem_center", 0.01},
                                      {"left_shoulder", 0.05},
                                      {"right_shoulder", 0.05}});
}

TEST(KeyPoints, ShirtsTurnedByAFewDegrees) {
  // The trials turn the garment by up to 5°: the armpits must not be taken for the
  // collar (they lie about W/6 from the centroid).
  for (double deg : {-5.0, -3.0, 3.0, 5.0}) {
    SCOPED_TRACE(deg);
    // Hems 2 cm: a hem corner is searched no further out than its armpit (+ 2 % of the
    // width, to keep sleeve points out), and a 5° turn moves the T-shirt's corner
    // 4 cm outwards relative to its armpit (found 1.5 cm off along the hem).
    const std::map<std::string, double> tol = {
        {"collar", 0.015}, {"left_armpit", 0.015}, {"right_armpit", 0.015}, {"left_hem", 0.02}, {"right_hem", 0.02}};
    CheckTemplate("long_sleeve_shirt", tol, deg * M_PI / 180);
    CheckTemplate("tshirt", tol, deg * M_PI / 180);
  }
}

TEST(KeyPoints, TshirtSleeveEnds) {
  CheckTemplate("tshirt", {{"left_sleeve_end", 0.02},
                           {"right_sleeve_end", 0.02},
                           {"collar", 0.01},
                           {"left_armpit", 0.01},
                           {"right_armpit", 0.01},
                           {"left_hem", 0.01},
                           {"right_hem", 0.01}});
}

TEST(KeyPoints, RotatedRectangleCorners) {
  // A 0.6 × 0.4 m towel turned by 8°: the diagonal extremes are its corners.
  const double c = std::cos(0.14), s = std::sin(0.14);
  std::vector<Vec2> poly;
  for (const Vec2& p : {Vec2(-0.3, -0.2), Vec2(0.3, -0.2), Vec2(0.3, 0.2), Vec2(-0.3, 0.2)})
    poly.emplace_back(c * p.x() - s * p.y(), s * p.x() + c * p.y());
  const Picture pic = Fill(poly);
  const auto k = DetectKeyPoints(pic.mask, "towel");
  EXPECT_LT((pic.ToPattern(k.at("bottom_left")) - poly[0]).norm(), 0.006);
  EXPECT_LT((pic.ToPattern(k.at("bottom_right")) - poly[1]).norm(), 0.006);
  EXPECT_LT((pic.ToPattern(k.at("top_right")) - poly[2]).norm(), 0.006);
  EXPECT_LT((pic.ToPattern(k.at("top_left")) - poly[3]).norm(), 0.006);
  EXPECT_LT(pic.ToPattern(k.at("center")).norm(), 0.003);
}

TEST(KeyPoints, RejectsEmptyMasksAndShapesWithoutTheirFeatures) {
  EXPECT_THROW(DetectKeyPoints(cv::Mat::zeros(50, 50, CV_8UC1), "towel"), Error);
  EXPECT_THROW(DetectKeyPoints(cv::Mat(), "towel"), Error);
  // A plain rectangle has no crotch.
  const Picture pic = Fill({Vec2(0, 0), Vec2(0.4, 0), Vec2(0.4, 0.8), Vec2(0, 0.8)});
  try {
    DetectKeyPoints(pic.mask, "pants");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("crotch"), std::string::npos) << e.what();
  }
  EXPECT_THROW(DetectKeyPoints(pic.mask, "sock"), Error);
}

}  // namespace
}  // namespace drape::folding
