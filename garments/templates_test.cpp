// Every template: topology, orientation, quality, anchors, dimensions, determinism.
#include "garments/templates.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>

#include "common/error.h"
#include "common/hash.h"
#include "garments/layers_testing.h"
#include "garments/validate.h"

namespace drape {
namespace {

// Stated mesh-quality bounds at the default edge length h (see anchors.md / report):
// every pattern edge within [0.4 h, 1.6 h], 90 % of them within [0.6 h, 1.35 h],
// smallest triangle angle ≥ 20° (what CGAL guarantees for B = 0.125).
constexpr double kRatioMin = 0.4, kRatioMax = 1.6, kRatioP05 = 0.6, kRatioP95 = 1.35;
constexpr double kMinAngleDeg = 20;
constexpr double kRatioMinTrouserWaist = 0.33;

// The paper's anchor counts (long-sleeve shirt 19, pants 12, shorts 8), towel 8+.
int RequiredAnchors(const std::string& name) {
  if (name == "long_sleeve_shirt") return 19;
  if (name == "pants") return 12;
  if (name == "shorts") return 8;
  if (name == "towel") return 8;
  return 8;
}

// Flat-layout width/height expected from the size parameters (written from the
// parameter definitions, independently of the outline code).
Vec2 ExpectedSize(const std::string& name, const std::map<std::string, double>& p) {
  if (name == "long_sleeve_shirt" || name == "tshirt") {
    const double half = std::max({p.at("shoulder_width") / 2 + p.at("sleeve_length") * std::cos(p.at("sleeve_angle")),
                                  p.at("chest_width") / 2, p.at("hem_width") / 2});
    return {2 * half, p.at("body_length")};
  }
  if (name == "pants" || name == "shorts") {
    const double half = std::max(p.at("hip_width") / 2, p.at("leg_gap") / 2 + p.at("leg_width"));
    return {2 * half, p.at("rise") + p.at("inseam") + p.at("back_waist_rise")};  // the back waist on top
  }
  if (name == "skirt") return {std::max(p.at("hem_width"), p.at("hip_width")), p.at("length")};
  if (name == "towel") return {p.at("width"), p.at("length")};
  ADD_FAILURE() << "no expected size for " << name;
  return {0, 0};
}

class TemplateTest : public ::testing::TestWithParam<std::string> {};

TEST_P(TemplateTest, MeshIsManifoldOrientedAndWellShaped) {
  const std::string name = GetParam();
  const TemplateInfo* info = FindTemplate(name);
  ASSERT_NE(info, nullptr);
  for (const std::string size : {"S", "M", "L"}) {
    SCOPED_TRACE(size);
    TemplateOptions opt;
    opt.size = size;
    MeshStats stats;
    const Garment g = MakeGarment(name, opt, &stats);
    EXPECT_EQ(g.category, name);
    EXPECT_EQ(g.instance, name + "-" + size);
    const MeshReport r = InspectMesh(g.mesh);
    EXPECT_TRUE(r.Manifold()) << r.nonmanifold_edges.size() << " non-manifold edges";
    EXPECT_TRUE(r.Oriented()) << r.inconsistent_edges << " inconsistent edges";
    EXPECT_TRUE(r.degenerate_faces.empty());
    EXPECT_EQ(r.components, 1);
    EXPECT_EQ(r.unreferenced_vertices, 0);
    EXPECT_EQ(r.boundary_loops, static_cast<int>(info->openings.size()));
    EXPECT_EQ(stats.boundary_loops, r.boundary_loops);
    EXPECT_EQ(stats.openings, static_cast<int>(info->openings.size()));
    EXPECT_TRUE(CheckGarment(g, name).empty());

    // No inverted triangles: front faces face +z, back faces −z, in the pattern too.
    // Front faces come first; every back face has a back vertex (faces of stitched
    // vertices only are excluded by construction).
    const Points3 n = FaceNormals(g.mesh);
    int front_faces = 0;
    auto has_back = [&](int f) {
      bool back = false;
      for (int k = 0; k < 3; ++k) back |= g.layer[g.mesh.F(f, k)] == 1;
      return back;
    };
    while (front_faces < g.mesh.NumFaces() && !has_back(front_faces)) ++front_faces;
    for (int f = 0; f < g.mesh.NumFaces(); ++f) {
      const bool is_front = f < front_faces;
      EXPECT_EQ(has_back(f), !is_front) << "face " << f;
      const double nz = n(f, 2);
      ASSERT_GT(is_front ? nz : -nz, 0.5) << "face " << f << " is inverted or steep";
      const Vec2 a = g.uv.row(g.mesh.F(f, 0)), b = g.uv.row(g.mesh.F(f, 1)), c = g.uv.row(g.mesh.F(f, 2));
      const double cross = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
      EXPECT_GT(is_front ? cross : -cross, 0) << "face " << f;
    }

    // Edge lengths relative to the target, smallest angle.
    // Trousers: the back waist's half ellipse is thinner than an edge within a few cm of
    // the waist corners, and the front's waist beside it is split finer there.
    EXPECT_GE(stats.ratio_min, name == "pants" || name == "shorts" ? kRatioMinTrouserWaist : kRatioMin);
    EXPECT_LE(stats.ratio_max, kRatioMax);
    EXPECT_GE(stats.ratio_p05, kRatioP05);
    EXPECT_LE(stats.ratio_p95, kRatioP95);
    EXPECT_GE(stats.min_angle_deg, kMinAngleDeg);
    // Bullet's CreateFromTriMesh is O(V²): stay small at the default edge length.
    EXPECT_LT(g.mesh.NumVertices(), 3000);

    // Layers: front z = +gap/2, back −gap/2, seam 0.
    for (int v = 0; v < g.mesh.NumVertices(); ++v) {
      const double z = g.mesh.V(v, 2);
      if (g.layer[v] == 1) {
        EXPECT_DOUBLE_EQ(z, -opt.layer_gap / 2);
      } else {
        EXPECT_TRUE(z == 0 || z == opt.layer_gap / 2);
      }
      EXPECT_EQ(g.mesh.V(v, 0), g.uv(v, 0));
      EXPECT_EQ(g.mesh.V(v, 1), g.uv(v, 1));
    }
  }
}

TEST_P(TemplateTest, AnchorsAreLabelledAndOnTheFrontLayer) {
  const std::string name = GetParam();
  const TemplateInfo* info = FindTemplate(name);
  const Garment g = MakeGarment(name, {});
  EXPECT_GE(static_cast<int>(g.anchors.size()), RequiredAnchors(name));
  ASSERT_EQ(g.anchors.size(), info->anchor_labels.size());
  std::set<int> vertices;
  std::set<std::string> labels;
  for (size_t i = 0; i < g.anchors.size(); ++i) {
    const Anchor& a = g.anchors[i];
    EXPECT_EQ(a.label, info->anchor_labels[i]);
    EXPECT_TRUE(labels.insert(a.label).second) << "duplicate " << a.label;
    EXPECT_TRUE(vertices.insert(a.vertex).second) << a.label << " shares its vertex";
    ASSERT_GE(a.vertex, 0);
    EXPECT_EQ(g.layer[a.vertex], 0) << a.label;
    EXPECT_EQ(a.position, Vec3(g.mesh.V.row(a.vertex)));
    // Snapped within one target edge of where the template put it.
    EXPECT_LT((Vec2(g.uv.row(a.vertex)) - a.uv).norm(), 0.025) << a.label;
    EXPECT_EQ(g.FindAnchor(a.label), &a);
  }
  // Both sides: every left_X has its right_X.
  for (const auto& l : labels) {
    if (l.rfind("left_", 0) == 0) {
      EXPECT_TRUE(labels.count("right_" + l.substr(5))) << l;
    }
    if (l.rfind("right_", 0) == 0) {
      EXPECT_TRUE(labels.count("left_" + l.substr(6))) << l;
    }
  }
}

TEST_P(TemplateTest, DimensionsMatchSizeParameters) {
  const std::string name = GetParam();
  double last_area = 0;
  for (const std::string size : {"S", "M", "L"}) {
    TemplateOptions opt;
    opt.size = size;
    const TemplateShape shape = MakeTemplateShape(name, opt);
    const Garment g = MakeGarment(name, opt);
    const MeshReport r = InspectMesh(g.mesh);
    const Vec2 want = ExpectedSize(name, shape.params);
    // Contour corners are mesh vertices, so the extent is exact up to rounding.
    EXPECT_NEAR(r.bounds_max.x() - r.bounds_min.x(), want.x(), 1e-9) << size;
    EXPECT_NEAR(r.bounds_max.y() - r.bounds_min.y(), want.y(), 1e-9) << size;
    EXPECT_NEAR(r.bounds_max.x() + r.bounds_min.x(), 0, 1e-9) << "centred on x = 0";
    EXPECT_NEAR(r.bounds_min.y(), 0, 1e-9);
    EXPECT_NEAR(r.bounds_max.z() - r.bounds_min.z(), opt.layer_gap, 1e-12);
    // Named widths between corner anchors (corners are exact vertices).
    auto dist = [&](const char* a, const char* b) {
      return (g.FindAnchor(a)->position - g.FindAnchor(b)->position).norm();
    };
    if (shape.params.count("waist_width")) {
      EXPECT_NEAR(dist("left_waist", "right_waist"), shape.params.at("waist_width"), 1e-9);
    }
    if (name == "long_sleeve_shirt" || name == "tshirt") {
      EXPECT_NEAR(dist("left_armpit", "right_armpit"), shape.params.at("chest_width"), 1e-9);
      EXPECT_NEAR(dist("left_hem", "right_hem"), shape.params.at("hem_width"), 1e-9);
      EXPECT_NEAR(dist("left_shoulder", "right_shoulder"), shape.params.at("shoulder_width"), 1e-9);
    }
    if (name == "pants" || name == "shorts") {
      EXPECT_NEAR(g.FindAnchor("crotch")->position.y(), shape.params.at("inseam"), 1e-9);
      EXPECT_NEAR(dist("left_leg_outer", "left_leg_inner"), shape.params.at("leg_width"), 1e-9);
    }
    const double area = SurfaceArea(g.mesh);
    EXPECT_GT(area, last_area) << size << " is not larger than the size before";
    last_area = area;
  }
}

TEST_P(TemplateTest, SeedsAreDeterministicAndDistinct) {
  const std::string name = GetParam();
  TemplateOptions a;
  a.seed = 7;
  const Garment g1 = MakeGarment(name, a), g2 = MakeGarment(name, a);
  ASSERT_EQ(g1.mesh.V.rows(), g2.mesh.V.rows());
  EXPECT_EQ(0, std::memcmp(g1.mesh.V.data(), g2.mesh.V.data(), sizeof(double) * g1.mesh.V.size()));
  EXPECT_EQ(g1.mesh.F, g2.mesh.F);
  EXPECT_EQ(g1.instance, name + "-M-s7");

  TemplateOptions b = a;
  b.seed = 8;
  const TemplateShape s7 = MakeTemplateShape(name, a), s8 = MakeTemplateShape(name, b),
                      s0 = MakeTemplateShape(name, {});
  int differ = 0, zero = 0;
  for (const auto& [k, v] : s0.params) {
    if (v == 0) {  // a difference off in every preset (back_hem_drop) stays off
      EXPECT_EQ(s7.params.at(k), 0) << k;
      ++zero;
      continue;
    }
    EXPECT_LE(std::abs(s7.params.at(k) / v - 1), a.perturbation + 1e-12) << k;
    differ += s7.params.at(k) != s8.params.at(k);
  }
  EXPECT_EQ(differ + zero, static_cast<int>(s0.params.size()));
  const MeshReport r7 = InspectMesh(g1.mesh), r8 = InspectMesh(MakeGarment(name, b).mesh);
  EXPECT_NE(r7.bounds_max.x(), r8.bounds_max.x());
}

TEST_P(TemplateTest, PerturbedInstancesStaySound) {
  // Larger perturbations than the default and a coarser and a finer mesh: the
  // topology guarantees must hold for every instance, not just the presets.
  const std::string name = GetParam();
  const TemplateInfo* info = FindTemplate(name);
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    for (double h : {0.02, 0.05}) {
      TemplateOptions o;
      o.seed = seed;
      o.perturbation = 0.1;
      o.edge_length = h;
      o.size = seed % 2 ? "S" : "L";
      const Garment g = MakeGarment(name, o);
      const MeshReport r = InspectMesh(g.mesh);
      EXPECT_TRUE(r.Manifold() && r.Oriented() && r.degenerate_faces.empty() && r.components == 1)
          << g.instance << " h=" << h;
      EXPECT_EQ(r.boundary_loops, static_cast<int>(info->openings.size())) << g.instance << " h=" << h;
      EXPECT_EQ(g.anchors.size(), info->anchor_labels.size());
    }
  }
}

INSTANTIATE_TEST_SUITE_P(All, TemplateTest,
                         ::testing::Values("long_sleeve_shirt", "tshirt", "pants", "shorts", "skirt", "towel"),
                         [](const auto& info) { return info.param; });

// Where a layer's boundary (mesh edges of one face; z > 0 front, z < 0 back) crosses the
// vertical line x = x0, in edge order: y of the crossing and the lower end of its edge.
struct Crossing {
  double y, edge_min_y;
};
std::vector<Crossing> BoundaryCrossings(const Garment& g, double z_sign, double x0) {
  std::map<std::pair<int, int>, int> faces;
  for (int f = 0; f < g.mesh.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int u = g.mesh.F(f, k), v = g.mesh.F(f, (k + 1) % 3);
      ++faces[{std::min(u, v), std::max(u, v)}];
    }
  std::vector<Crossing> out;
  for (const auto& [e, n] : faces) {
    if (n != 1) continue;
    const Vec2 a = g.uv.row(e.first), b = g.uv.row(e.second);
    if (g.mesh.V(e.first, 2) * z_sign <= 0 && g.mesh.V(e.second, 2) * z_sign <= 0) continue;
    if (a.x() == b.x() || (a.x() > x0) == (b.x() > x0)) continue;
    out.push_back({a.y() + (b.y() - a.y()) * (x0 - a.x()) / (b.x() - a.x()), std::min(a.y(), b.y())});
  }
  return out;
}

// Where a layer's opening crosses the centre line x = 0 above y_min: y of the mesh
// boundary edge of that layer (z > 0 front, z < 0 back) there; NaN if there is none.
double OpeningAtCentre(const Garment& g, double z_sign, double y_min) {
  for (const Crossing& c : BoundaryCrossings(g, z_sign, 0))
    if (c.edge_min_y >= y_min) return c.y;
  return std::nan("");
}

// The front/back difference of the flat pattern, measured on the mesh: shirts' back
// neckline shallower by back_neck_rise, trousers' back waist higher by back_waist_rise;
// the skirt's the same on both layers; the seams stitched vertex to vertex.
TEST_P(TemplateTest, FrontAndBackDifferByTheStatedAmounts) {
  const std::string name = GetParam();
  for (const std::string size : {"S", "M", "L"}) {
    SCOPED_TRACE(size);
    TemplateOptions opt;
    opt.size = size;
    const TemplateShape shape = MakeTemplateShape(name, opt);
    const Garment g = MakeGarment(name, opt);
    const testing::LayerSeams m = testing::MeasureLayers(g);
    EXPECT_EQ(m.stitched_edges_not_one_per_layer, 0);
    EXPECT_GT(m.front_seam_edges, 10);
    EXPECT_EQ(m.front_seam_edges, m.back_seam_edges);
    EXPECT_EQ(m.front_seam_length, m.back_seam_length);
    const auto& p = shape.params;
    const double top = InspectMesh(g.mesh).bounds_max.y();
    const double front = OpeningAtCentre(g, +1, top / 2), back = OpeningAtCentre(g, -1, top / 2);
    if (name == "long_sleeve_shirt" || name == "tshirt") {
      // Front neck drop 7–9 cm, back 1.8–2.2 cm; the front's neckline a polygon through
      // a half ellipse (within 1.5 mm of it at the centre), the back's parabola's bottom a vertex.
      const double H = p.at("body_length"), nd = p.at("neck_depth"), rise = p.at("back_neck_rise");
      EXPECT_NEAR(H - front, nd, 0.0015);
      EXPECT_NEAR(H - back, nd - rise, 1e-12);
      EXPECT_NEAR(nd - rise, size == "S" ? 0.018 : size == "M" ? 0.020 : 0.022, 1e-12);
      // Between the front's half ellipse and the back's parabola.
      const double bd = nd - rise, nw = p.at("neck_width");
      EXPECT_NEAR(m.back_area - m.front_area, M_PI / 4 * nw * nd - 2.0 / 3 * nw * bd, 0.02 * nw * nd);
    } else if (name == "pants" || name == "shorts") {
      // The back waist 3–4 cm above the front's at the centre; the waist corners shared.
      const double H = p.at("rise") + p.at("inseam"), rise = p.at("back_waist_rise");
      EXPECT_EQ(front, H);
      EXPECT_EQ(back, H + rise);  // the half ellipse's top is a vertex
      EXPECT_NEAR(rise, size == "S" ? 0.03 : size == "M" ? 0.035 : 0.04, 1e-12);
      EXPECT_NEAR(m.back_area - m.front_area, M_PI / 4 * p.at("waist_width") * rise, 0.02 * p.at("waist_width") * rise);
      EXPECT_EQ(g.FindAnchor("waist_center")->position.y(), H);  // on the front's waistband
      EXPECT_GT(g.FindAnchor("waist_center")->position.z(), 0);
    } else if (name == "skirt") {
      EXPECT_EQ(front, back);
      EXPECT_EQ(m.front_area, m.back_area);
    } else {
      EXPECT_TRUE(std::isnan(front) && std::isnan(back));  // the towel: no opening
      EXPECT_EQ(m.front_area, m.back_area);
    }
  }
}

// With the front/back difference at 0 the garment is the symmetric one of before
// (quickstart 2.3.0's code): the back the front's mirror, bit for bit. Checked when the
// difference came in: `drape garments make` of these four, with the parameter at 0,
// wrote PLY files byte-identical to that code's; the digests (of the doubles) guard
// the symmetric layout from now on.
std::string MeshDigest(const Garment& g) {
  std::string bytes(reinterpret_cast<const char*>(g.mesh.V.data()), sizeof(double) * g.mesh.V.size());
  bytes.append(reinterpret_cast<const char*>(g.mesh.F.data()), sizeof(int) * g.mesh.F.size());
  bytes.append(reinterpret_cast<const char*>(g.uv.data()), sizeof(double) * g.uv.size());
  for (int l : g.layer) bytes += static_cast<char>('0' + l);
  for (const Anchor& a : g.anchors) bytes += a.label + ":" + std::to_string(a.vertex) + ";";
  return Sha256Hex(bytes).substr(0, 16);
}

TEST(Templates, ZeroFrontBackDifferenceIsTheSymmetricGarment) {
  struct Case {
    std::string name, param;
    uint64_t seed;
    double h;
    std::string digest;
  };
  for (const Case& c : {Case{"long_sleeve_shirt", "back_neck_rise", 0, 0.025, "ea1ac0c3a14508c1"},
                        Case{"tshirt", "back_neck_rise", 5, 0.035, "b2560c323a80571f"},
                        Case{"pants", "back_waist_rise", 0, 0.025, "1204bd50d600f923"},
                        Case{"shorts", "back_waist_rise", 3, 0.035, "3213eb381a3dfb67"}}) {
    SCOPED_TRACE(c.name);
    TemplateOptions o;
    o.seed = c.seed;
    o.edge_length = c.h;
    o.params[c.param] = 0;
    const Garment g = MakeGarment(c.name, o);
    const testing::LayerSeams m = testing::MeasureLayers(g);
    EXPECT_EQ(m.front_area, m.back_area);
    // Mirrored layers: every back vertex has a front twin at the same uv, and the back
    // faces are the front's reversed.
    const int nv = g.mesh.NumVertices(), nf = g.mesh.NumFaces();
    int back = 0;
    for (int v = 0; v < nv; ++v) back += g.layer[v];
    EXPECT_EQ(nf % 2, 0);
    EXPECT_LT(back, nv / 2);
    EXPECT_EQ(MeshDigest(g), c.digest);
  }
}

// The lowest point where a layer's boundary (z > 0 front, z < 0 back) crosses x = x0.
double LowestOpeningAt(const Garment& g, double z_sign, double x0) {
  double lowest = std::nan("");
  for (const Crossing& c : BoundaryCrossings(g, z_sign, x0))
    if (!(c.y >= lowest)) lowest = c.y;
  return lowest;
}

// back_hem_drop (off in every preset): the shirt's back hem lies lower than the front's by
// the stated amount, straight across, the extra strip of cloth the back's (the side seams
// open along it: vents); the seams stay stitched vertex to vertex, the anchors where they
// were (hem_center on the front's hem, the hem corners stitched), and the mesh as sound as
// the presets'.
TEST(Templates, BackHemDropLowersTheBackHemOnly) {
  struct Case {
    std::string name, size;
    double drop;
    uint64_t seed;
    double h;
  };
  for (const Case& c :
       {Case{"long_sleeve_shirt", "M", 0.0254, 0, 0.025}, Case{"long_sleeve_shirt", "L", 0.0254, 0, 0.035},
        Case{"long_sleeve_shirt", "S", 0.05, 5, 0.035}, Case{"long_sleeve_shirt", "M", 0.01, 2, 0.035},
        Case{"tshirt", "M", 0.0254, 3, 0.025}}) {
    SCOPED_TRACE(c.name + " " + c.size + " drop " + std::to_string(c.drop) + " h " + std::to_string(c.h));
    TemplateOptions o;
    o.size = c.size;
    o.seed = c.seed;
    o.edge_length = c.h;
    const Garment g0 = MakeGarment(c.name, o);
    o.params["back_hem_drop"] = c.drop;
    const TemplateShape shape = MakeTemplateShape(c.name, o);
    MeshStats stats;
    const Garment g = MakeGarment(c.name, o, &stats);
    const TemplateInfo* info = FindTemplate(c.name);
    const MeshReport r = InspectMesh(g.mesh);
    EXPECT_TRUE(r.Manifold() && r.Oriented() && r.degenerate_faces.empty() && r.components == 1);
    EXPECT_EQ(r.boundary_loops, static_cast<int>(info->openings.size()));
    EXPECT_TRUE(CheckGarment(g, c.name).empty());
    EXPECT_GE(stats.ratio_min, kRatioMin);
    EXPECT_LE(stats.ratio_max, kRatioMax);
    EXPECT_GE(stats.min_angle_deg, kMinAngleDeg);
    EXPECT_EQ(r.bounds_min.y(), -c.drop);
    EXPECT_EQ(r.bounds_max.y(), InspectMesh(g0.mesh).bounds_max.y());
    EXPECT_EQ(r.bounds_max.x(), InspectMesh(g0.mesh).bounds_max.x());
    // Seams: the same on both layers, and the same as without the drop (only the hem changes).
    const testing::LayerSeams m = testing::MeasureLayers(g), m0 = testing::MeasureLayers(g0);
    EXPECT_EQ(m.stitched_edges_not_one_per_layer, 0);
    EXPECT_EQ(m.front_seam_edges, m.back_seam_edges);
    EXPECT_EQ(m.front_seam_length, m.back_seam_length);
    EXPECT_NEAR(m.front_seam_length, m0.front_seam_length, 1e-9);
    // Front hem at y = 0, the back's at −drop, all across.
    const double hw = shape.params.at("hem_width");
    for (double x : {0.0, 0.3 * hw, -0.45 * hw}) {
      EXPECT_NEAR(LowestOpeningAt(g, +1, x), 0, 1e-12) << x;
      EXPECT_NEAR(LowestOpeningAt(g, -1, x), -c.drop, 1e-12) << x;
      EXPECT_NEAR(LowestOpeningAt(g0, -1, x), 0, 1e-12) << x;
    }
    // The extra cloth is the back's: a strip hem_width × drop; the front is unchanged.
    EXPECT_NEAR(m.front_area, m0.front_area, 1e-9);
    EXPECT_NEAR(m.back_area - m0.back_area, hw * c.drop, 1e-9);
    // Anchors: on the front layer within one edge of where the template put it (the same
    // uv as without the drop); the hem corners exactly where they were, the hem's centre on
    // the front's hem (the front hem's vertices may move along it).
    ASSERT_EQ(g.anchors.size(), g0.anchors.size());
    for (const Anchor& a : g.anchors) {
      EXPECT_EQ(g.layer[a.vertex], 0) << a.label;
      EXPECT_LT((Vec2(g.uv.row(a.vertex)) - a.uv).norm(), c.h) << a.label;
      EXPECT_EQ(a.uv, g0.FindAnchor(a.label)->uv) << a.label;
    }
    for (const char* l : {"left_hem", "right_hem"}) {
      EXPECT_EQ(g.FindAnchor(l)->position, g0.FindAnchor(l)->position) << l;
    }
    EXPECT_EQ(g.FindAnchor("hem_center")->position.y(), 0);
    EXPECT_GT(g.FindAnchor("hem_center")->position.z(), 0);  // the front's hem, not stitched
    EXPECT_EQ(g.FindAnchor("left_hem")->position.z(), 0);    // the corners stay stitched
    // 0 is the garment of before, bit for bit.
    o.params["back_hem_drop"] = 0;
    EXPECT_EQ(MeshDigest(MakeGarment(c.name, o)), MeshDigest(g0));
  }
}

TEST(Templates, BackHemDropTooLargeIsNamed) {
  for (const char* name : {"long_sleeve_shirt", "tshirt"}) {
    TemplateOptions o;
    o.params["back_hem_drop"] = 0.5;
    try {
      MakeGarment(name, o);
      ADD_FAILURE() << name;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("back_hem_drop"), std::string::npos) << e.what();
    }
  }
}

TEST(Templates, ListIsComplete) {
  std::set<std::string> names;
  for (const auto& t : Templates()) {
    names.insert(t.name);
    EXPECT_FALSE(t.parameters.empty());
    EXPECT_FALSE(t.description.empty());
  }
  for (const char* n : {"long_sleeve_shirt", "tshirt", "pants", "shorts", "skirt", "towel"})
    EXPECT_TRUE(names.count(n)) << n;
  EXPECT_EQ(FindTemplate("nope"), nullptr);
}

TEST(Templates, ParameterOverridesAreExactAndChecked) {
  TemplateOptions o;
  o.seed = 3;
  o.params["inseam"] = 0.7;
  const TemplateShape s = MakeTemplateShape("pants", o);
  EXPECT_EQ(s.params.at("inseam"), 0.7);
  EXPECT_EQ(s.instance.rfind("pants-M-s3-p", 0), 0u);
  o.params["insaem"] = 0.7;
  try {
    MakeTemplateShape("pants", o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("insaem"), std::string::npos) << e.what();
  }
}

TEST(Templates, BadOptionsAreNamed) {
  auto message = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message([] { MakeGarment("cape", {}); }).find("cape"), std::string::npos);
  TemplateOptions o;
  o.size = "XL";
  EXPECT_NE(message([&] { MakeGarment("pants", o); }).find("size"), std::string::npos);
  o = {};
  o.edge_length = 0;
  EXPECT_NE(message([&] { MakeGarment("pants", o); }).find("edge_length"), std::string::npos);
  o = {};
  o.params["neck_width"] = 0.6;  // wider than the shoulders
  EXPECT_NE(message([&] { MakeGarment("tshirt", o); }).find("neck_width"), std::string::npos);
}

TEST(Templates, PrintStats) {
  // Not a check: the numbers quoted in the report.
  for (const auto& t : Templates()) {
    MeshStats s;
    const Garment g = MakeGarment(t.name, {}, &s);
    std::printf(
        "%-18s V=%5d F=%5d front=%4d seam=%3d anchors=%2zu loops=%d edge mean=%.4f "
        "ratio[min %.2f p05 %.2f p95 %.2f max %.2f] min_angle=%.1f area=%.3f rounds=%d\n",
        t.name.c_str(), s.vertices, s.faces, s.front_vertices, s.seam_vertices, g.anchors.size(), s.boundary_loops,
        s.edge_mean, s.ratio_min, s.ratio_p05, s.ratio_p95, s.ratio_max, s.min_angle_deg, s.area, s.refine_rounds);
  }
}

}  // namespace
}  // namespace drape
