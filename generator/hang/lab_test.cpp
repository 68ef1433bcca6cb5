// The textile lab's tests on the cloth core, at their limits: a sheet meshed like the
// garments; a stiff disc barely drapes and a limp one does; a sheet on a sheet stays on
// a level plane and slides off a steep one; a fold creases only past the yield.
#include "generator/hang/lab.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "common/error.h"
#include "generator/hang/material.h"

namespace drape {
namespace {

constexpr double kPi = std::numbers::pi;

LabCloth Cloth(double B, double yield = 0) {
  LabCloth c;
  c.material.name = "lab";
  c.material.area_density = 0.2;
  c.material.bending_rigidity = B;
  c.material.crease_yield = yield;
  c.material.crease_weakening = yield > 0 ? 1 : 0;
  c.fit.stiffness = 0.8;
  c.fit.friction = c.fit.cloth_friction = std::tan(25 * kPi / 180);
  return c;
}

TEST(Lab, MeshedSheetIsAFlatDiscMeshedAsTheGarments) {
  std::vector<Vec2> circle;
  circle.reserve(120);
  for (int k = 0; k < 120; ++k)
    circle.emplace_back(0.1 * std::cos(2 * kPi * k / 120), 0.1 * std::sin(2 * kPi * k / 120));
  const TriMesh s = MeshedSheet(circle, 0.02);
  EXPECT_NEAR(FaceAreas(s).sum(), kPi * 0.01, 0.002);
  EXPECT_EQ(s.V.col(2).cwiseAbs().maxCoeff(), 0);
  for (int f = 0; f < s.NumFaces(); ++f) {
    const Vec3 a = s.V.row(s.F(f, 0)), b = s.V.row(s.F(f, 1)), c = s.V.row(s.F(f, 2));
    EXPECT_GT((b - a).cross(c - a).z(), 0) << f;  // counter-clockwise seen from +z
  }
  EXPECT_EQ(ConnectedComponents(s), 1);
}

// The drape coefficient runs from 0 (hangs straight down) to 1 (stays flat).
TEST(Lab, AStiffDiscBarelyDrapesAndALimpOneDoes) {
  DrapeOptions o;
  o.edge_length = 0.03;
  o.seeds = {1};
  o.settle_time = 4;
  const DrapeResult stiff = RunDrape(Cloth(2e-3), o), limp = RunDrape(Cloth(2e-6), o);
  ASSERT_EQ(stiff.runs.size(), 1u);
  EXPECT_TRUE(stiff.runs[0].failure.empty()) << stiff.runs[0].failure;
  EXPECT_GT(stiff.drape_coefficient, 0.85);
  EXPECT_LT(limp.drape_coefficient, 0.6);
  EXPECT_GE(limp.folds[0], 3);
  DrapeOptions bad = o;
  bad.disc_diameter = 0.4;
  EXPECT_THROW(RunDrape(Cloth(2e-5), bad), Error);
}

TEST(Lab, ASheetOnASheetStaysLevelAndSlidesOffASteepIncline) {
  InclineOptions o;
  o.edge_length = 0.04;
  o.time = 1;
  o.angle_deg = 0;
  const InclineResult level = RunIncline(Cloth(2e-5), o);
  EXPECT_TRUE(level.failure.empty()) << level.failure;
  EXPECT_LT(level.slide, 0.001);
  EXPECT_FALSE(level.slid_off);
  o.angle_deg = 50;  // far above the friction angle (25°): ~4.6 m/s², off the base in ~0.26 s
  const InclineResult steep = RunIncline(Cloth(2e-5), o);
  EXPECT_TRUE(steep.slid_off);
  EXPECT_GT(steep.off_time, 0.1);
  EXPECT_LT(steep.off_time, o.time);
  // The run stops where the sheet leaves the base: the slide is the base's half, not the fall.
  EXPECT_GE(steep.slide, o.base / 2);
  EXPECT_LT(steep.slide, o.base / 2 + 0.05);
}

// Folded 180° and pressed: without plasticity the strip springs back open; past its
// yield curvature it keeps part of the fold.
TEST(Lab, AFoldCreasesOnlyPastTheYield) {
  CreaseOptions o;
  o.edge_length = 0.025;
  o.press_time = 0.1;
  o.recovery_time = 2;
  const CreaseResult elastic = RunCrease(Cloth(2e-5), o), creased = RunCrease(Cloth(2e-5, 30), o);
  EXPECT_TRUE(elastic.failure.empty()) << elastic.failure;
  EXPECT_EQ(elastic.rest_angle, 0);
  EXPECT_GT(creased.rest_angle, 60);
  EXPECT_GT(elastic.open_angle, creased.open_angle + 30);
}

// A material with a measured crease recovery angle: FitMaterial fits the yield whose
// crease test at the fit's edge opens to it (shirting: 77.5°, untreated cotton), and the
// test run again with that fit reads the same; jersey (no yield) springs open further.
TEST(Lab, FitMaterialFitsTheYieldToTheMeasuredRecovery) {
  const Material& shirting = *FindMaterialPreset("shirting");
  ASSERT_GT(shirting.crease_recovery_deg, 0);
  const HangOptions o;
  const MaterialFit fit = FitMaterial(shirting, o);
  EXPECT_TRUE(fit.converged) << fit.note;
  EXPECT_GT(fit.crease_yield, 0);
  EXPECT_NEAR(fit.reproduced_crease_recovery_deg, shirting.crease_recovery_deg, 1.0);
  EXPECT_LE(fit.crease_iterations, 2 * o.fit_max_iterations);
  LabCloth c{shirting, fit, o};
  c.fit.cloth_friction = shirting.FrictionCoefficient();
  const CreaseResult again = RunCrease(c, CreaseOptionsAt(o.fit_edge_length));
  EXPECT_EQ(again.open_angle, fit.reproduced_crease_recovery_deg);
  LabCloth jersey{*FindMaterialPreset("tshirt"), fit, o};  // its own B and weight, no yield
  EXPECT_GT(RunCrease(jersey, CreaseOptionsAt(o.fit_edge_length)).open_angle, again.open_angle + 60);
}

TEST(Lab, CreaseRecoveryIsCheckedWhereItIsGiven) {
  Material m = *FindMaterialPreset("shirting");
  m.crease_yield = 30;
  EXPECT_THROW(m.Validate(), Error);  // both: the yield is fitted to the recovery
  m.crease_yield = 0;
  m.crease_recovery_deg = 180;
  EXPECT_THROW(m.Validate(), Error);
  m.crease_recovery_deg = 77.5;
  m.bending_rigidity = 0;
  EXPECT_THROW(m.Validate(), Error);  // creases live on the hinges
}

}  // namespace
}  // namespace drape
