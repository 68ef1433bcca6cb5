// Contour → two-sided garment on hand-made polygons and masks.
#include "garments/contour.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/testing.h"
#include "garments/layers_testing.h"
#include "garments/validate.h"

namespace drape {
namespace {

double PolygonArea(const std::vector<Vec2>& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec2 &u = p[i], &v = p[(i + 1) % p.size()];
    a += u.x() * v.y() - v.x() * u.y();
  }
  return std::abs(0.5 * a);
}

void ExpectSound(const Garment& g, int loops) {
  const MeshReport r = InspectMesh(g.mesh);
  EXPECT_TRUE(r.Manifold()) << r.nonmanifold_edges.size() << " non-manifold edges";
  EXPECT_TRUE(r.Oriented());
  EXPECT_TRUE(r.degenerate_faces.empty());
  EXPECT_EQ(r.components, 1);
  EXPECT_EQ(r.boundary_loops, loops);
  EXPECT_EQ(r.unreferenced_vertices, 0);
  EXPECT_TRUE(CheckGarment(g, "test").empty());
}

// A hand-made "L" with two openings: the top edge and the end of the foot.
Contour LShape() {
  Contour c;
  c.points = {{0, 0}, {0.5, 0}, {0.5, 0.2}, {0.2, 0.2}, {0.2, 0.6}, {0, 0.6}};
  c.edge_tag = {"", "foot", "", "", "top", ""};
  return c;
}

TEST(Contour, HandMadePolygonWithOpenings) {
  const Contour c = LShape();
  ContourOptions o;
  o.edge_length = 0.02;
  MeshStats s;
  const Garment g = GarmentFromContour(c, {{"heel", {0, 0}}, {"toe", {0.5, 0.1}}}, o, "boot", "b1", &s);
  ExpectSound(g, 2);
  EXPECT_EQ(s.openings, 2);
  EXPECT_EQ(s.boundary_loops, 2);
  EXPECT_EQ(g.category, "boot");
  EXPECT_EQ(g.instance, "b1");
  // Straight outline: the pattern area is exactly the polygon's; both layers together
  // (slightly tilted near the seams) at least twice that.
  EXPECT_NEAR(s.area, PolygonArea(c.points), 1e-12);
  EXPECT_GE(SurfaceArea(g.mesh), 2 * PolygonArea(c.points) - 1e-12);
  EXPECT_LT(SurfaceArea(g.mesh), 2 * PolygonArea(c.points) * 1.01);
  EXPECT_GE(s.ratio_min, 0.4);
  EXPECT_LE(s.ratio_max, 1.6);
  EXPECT_GE(s.min_angle_deg, 20);
  // Seam vertices at z = 0 and shared; opening vertices doubled at ±gap/2.
  int seam = 0, back = 0;
  for (int v = 0; v < g.mesh.NumVertices(); ++v) {
    if (g.mesh.V(v, 2) == 0) ++seam;
    if (g.layer[v] == 1) ++back;
  }
  EXPECT_EQ(seam, s.seam_vertices);
  EXPECT_EQ(back + s.front_vertices, g.mesh.NumVertices());
  // Anchors on the front layer at the requested places.
  ASSERT_EQ(g.anchors.size(), 2u);
  EXPECT_EQ(g.anchors[0].position, Vec3(0, 0, 0));  // a seam corner
  EXPECT_EQ(g.layer[g.anchors[1].vertex], 0);
  EXPECT_NEAR(g.anchors[1].position.z(), o.layer_gap / 2, 1e-15);  // on the foot opening, front copy
}

TEST(Contour, ClockwiseInputGivesTheSameGarmentShape) {
  Contour c = LShape(), r;
  const size_t n = c.points.size();
  for (size_t i = 0; i < n; ++i) {
    r.points.push_back(c.points[n - 1 - i]);
    // Edge i of the reversed polygon runs p[n-1-i] → p[n-2-i] = old edge n-2-i.
    r.edge_tag.push_back(c.edge_tag[(2 * n - 2 - i) % n]);
  }
  MeshStats a, b;
  const Garment ga = GarmentFromContour(c, {}, {}, "x", "", &a);
  const Garment gb = GarmentFromContour(r, {}, {}, "x", "", &b);
  ExpectSound(gb, 2);
  EXPECT_EQ(a.openings, b.openings);
  EXPECT_NEAR(a.area, b.area, 1e-12);
}

TEST(Contour, SharpSpikesAreSplitSoLayersStayManifold) {
  // Narrow spikes (≈ 10° tips) force triangles whose three corners are all on a seam.
  Contour c;
  c.points = {{0, 0}, {0.3, 0}, {0.3, 0.2}, {0.18, 0.2}, {0.15, 0.55}, {0.12, 0.2}, {0, 0.2}};
  ContourOptions o;
  MeshStats s;
  const Garment g = GarmentFromContour(c, {}, o, "spike", "", &s);
  ExpectSound(g, 0);
  EXPECT_NEAR(s.area, PolygonArea(c.points), 1e-12);
}

// The L with its top opening's back edge at `apex` (between the top corners (0.2, 0.6)
// and (0, 0.6), in contour order): above the top, the back has cloth the front lacks;
// below it, the front has.
Contour LWithBackTop(const Vec2& apex) {
  Contour c = LShape();
  c.back_openings["top"] = {{0.2, 0.6}, apex, {0, 0.6}};
  return c;
}

TEST(Contour, BackOpeningEdgeOfItsOwn) {
  for (const Vec2& apex : {Vec2(0.1, 0.7), Vec2(0.1, 0.5)}) {
    SCOPED_TRACE(apex.y());
    const Contour c = LWithBackTop(apex);
    ContourOptions o;
    o.edge_length = 0.02;
    MeshStats s;
    const Garment g = GarmentFromContour(c, {{"top_mid", {0.1, 0.6}}}, o, "boot", "", &s);
    ExpectSound(g, 2);
    EXPECT_EQ(s.openings, 2);
    // Each layer is its own pattern: the front the L, the back the L with the top
    // replaced by the two edges to the apex (a triangle of 0.2 × 0.1 / 2 more or less).
    const testing::LayerSeams m = testing::MeasureLayers(g);
    const double l = PolygonArea(c.points), tri = 0.5 * 0.2 * 0.1;
    EXPECT_NEAR(m.front_area, l, 1e-12);
    EXPECT_NEAR(m.back_area, apex.y() > 0.6 ? l + tri : l - tri, 1e-12);
    EXPECT_NEAR(s.area, l, 1e-12);
    EXPECT_NEAR(m.front_max_y, 0.6, 1e-15);
    EXPECT_NEAR(m.back_max_y, std::max(0.6, apex.y()), 1e-15);
    // Seams stitched vertex to vertex: every edge between stitched vertices has one
    // face on each layer, so both layers' seams have the same length (the outline less
    // the two openings).
    EXPECT_EQ(m.stitched_edges_not_one_per_layer, 0);
    EXPECT_NEAR(m.front_seam_length, 0.5 + 0.3 + 0.4 + 0.6, 1e-12);
    EXPECT_EQ(m.front_seam_length, m.back_seam_length);
    // Vertices: the front's uv inside the L, the back's inside its own pattern; the
    // anchor on the front's top edge.
    EXPECT_EQ(g.layer[g.anchors[0].vertex], 0);
    EXPECT_NEAR(g.anchors[0].position.z(), o.layer_gap / 2, 1e-15);
    EXPECT_NEAR(g.anchors[0].position.y(), 0.6, 1e-15);
  }
}

TEST(Contour, BackOpeningEdgeReversedWithTheContour) {
  // Clockwise input: the back edge is given in that order too and reversed with it.
  Contour c = LWithBackTop({0.1, 0.7}), r;
  const size_t n = c.points.size();
  for (size_t i = 0; i < n; ++i) {
    r.points.push_back(c.points[n - 1 - i]);
    r.edge_tag.push_back(c.edge_tag[(2 * n - 2 - i) % n]);
  }
  r.back_openings["top"] = {{0, 0.6}, {0.1, 0.7}, {0.2, 0.6}};
  MeshStats a, b;
  const Garment ga = GarmentFromContour(c, {}, {}, "x", "", &a);
  const Garment gb = GarmentFromContour(r, {}, {}, "x", "", &b);
  ExpectSound(gb, 2);
  EXPECT_NEAR(testing::MeasureLayers(ga).back_area, testing::MeasureLayers(gb).back_area, 1e-12);
}

TEST(Contour, BadBackOpeningEdgesAreNamed) {
  auto make = [](const Contour& c) { return ErrorOf([&] { GarmentFromContour(c, {}, {}); }); };
  Contour c = LShape();
  c.back_openings["heel"] = {{0, 0}, {0.1, 0.1}};
  EXPECT_NE(make(c).find("'heel', which is not an opening"), std::string::npos) << make(c);
  c = LWithBackTop({0.1, 0.7});
  c.back_openings["top"].back() = Vec2(0.05, 0.6);
  EXPECT_NE(make(c).find("must run from (0.2, 0.6) to (0, 0.6)"), std::string::npos) << make(c);
  // Zigzag across the front's top edge.
  c = LShape();
  c.back_openings["top"] = {{0.2, 0.6}, {0.15, 0.65}, {0.05, 0.55}, {0, 0.6}};
  EXPECT_NE(make(c).find("crosses its front edge"), std::string::npos) << make(c);
  // Its points outside, but an edge through the L (a coarse mesh: no points between).
  c = LShape();
  c.back_openings["top"] = {{0.2, 0.6}, {0.1, 0.75}, {0.1, -0.1}, {0, 0.6}};
  ContourOptions coarse;
  coarse.edge_length = 1;
  const std::string through = ErrorOf([&] { GarmentFromContour(c, {}, coarse); });
  EXPECT_NE(through.find("not simple"), std::string::npos) << through;
}

TEST(Contour, FromMaskOfADisc) {
  const int n = 400;
  const double mpp = 0.001, radius_px = 150;
  cv::Mat mask = cv::Mat::zeros(n, n, CV_8UC1);
  cv::circle(mask, {200, 200}, static_cast<int>(radius_px), cv::Scalar(255), cv::FILLED);
  cv::circle(mask, {20, 20}, 8, cv::Scalar(255), cv::FILLED);  // a speck: ignored
  MaskOptions mo;
  mo.metres_per_pixel = mpp;
  const Contour c = ContourFromMask(mask, mo);
  // The disc's outline: centre (200.5 px, n − 200.5 px) in metres, radius 0.15 m.
  for (const Vec2& p : c.points) EXPECT_NEAR((p - Vec2(0.2005, 0.1995)).norm(), 0.15, 0.0025);
  MeshStats s;
  const Garment g = GarmentFromContour(c, {{"middle", {0.2, 0.2}}}, {}, "disc", "", &s);
  ExpectSound(g, 0);  // no openings: a closed two-layer shell
  EXPECT_NEAR(s.area, M_PI * 0.15 * 0.15, 0.01 * M_PI * 0.15 * 0.15);
  EXPECT_LT((g.anchors[0].uv - Vec2(g.uv.row(g.anchors[0].vertex))).norm(), 0.025);
}

TEST(Contour, FromMaskTouchingTheBorder) {
  cv::Mat mask(100, 200, CV_8UC1, cv::Scalar(255));  // all foreground
  MaskOptions mo;
  mo.metres_per_pixel = 0.005;
  const Contour c = ContourFromMask(mask, mo);
  const Garment g = GarmentFromContour(c, {}, {}, "rect", "");
  ExpectSound(g, 0);
  EXPECT_NEAR(InspectMesh(g.mesh).bounds_max.x() - InspectMesh(g.mesh).bounds_min.x(), 199 * 0.005, 1e-9);
}

TEST(Contour, BadContoursAreNamed) {
  auto make = [](Contour c) { return ErrorOf([&] { GarmentFromContour(c, {}, {}); }); };
  EXPECT_NE(make({{{0, 0}, {1, 0}}, {}, {}}).find("2 points"), std::string::npos);
  EXPECT_NE(make({{{0, 0}, {1, 0}, {1, 0}, {0, 1}}, {}, {}}).find("points 1 and 2 coincide"), std::string::npos);
  const std::string bowtie = make({{{0, 0}, {1, 1}, {1, 0}, {0, 1}}, {}, {}});
  EXPECT_NE(bowtie.find("not simple: edge 0"), std::string::npos) << bowtie;
  EXPECT_NE(make({{{0, 0}, {1, 0}, {0, 1}}, {"", ""}, {}}).find("3 points but 2 edge tags"), std::string::npos);
  EXPECT_NE(make({{{0, 0}, {1, 0}, {0, 1}}, {"a", "a", "a"}, {}}).find("no seam edge"), std::string::npos);
  EXPECT_NE(make({{{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {"a", "b", "", ""}, {}}).find("openings 'a' and 'b' touch"),
            std::string::npos);
  EXPECT_NE(make({{{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {"a", "", "a", ""}, {}}).find("opening 'a' appears twice"),
            std::string::npos);
  EXPECT_NE(make({{{0, 0}, {1, 0}, {2, 0}}, {}, {}}).find("zero area"), std::string::npos);
  ContourOptions o;
  o.edge_length = -1;
  EXPECT_NE(ErrorOf([&] { GarmentFromContour(LShape(), {}, o); }).find("edge_length"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { ContourFromMask(cv::Mat::zeros(10, 10, CV_8UC1), {}); }).find("no foreground"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { ContourFromMask(cv::Mat::zeros(10, 10, CV_32FC1), {}); }).find("8-bit"), std::string::npos);
}

TEST(Contour, FinerEdgeLengthGivesMoreVertices) {
  ContourOptions coarse, fine;
  coarse.edge_length = 0.04;
  fine.edge_length = 0.02;
  MeshStats a, b;
  GarmentFromContour(LShape(), {}, coarse, "x", "", &a);
  GarmentFromContour(LShape(), {}, fine, "x", "", &b);
  // Vertex count scales with 1/h²: about 4× (boundary effects aside).
  EXPECT_GT(b.front_vertices, 3 * a.front_vertices);
  EXPECT_NEAR(a.edge_mean / coarse.edge_length, 1.0, 0.15);
  EXPECT_NEAR(b.edge_mean / fine.edge_length, 1.0, 0.15);
}

}  // namespace
}  // namespace drape
