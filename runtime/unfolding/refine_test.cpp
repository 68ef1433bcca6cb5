#include "runtime/unfolding/refine.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "common/rng.h"

namespace drape::unfolding {
namespace {

TEST(Refine, KernelIsTheLaplacianOfGaussian) {
  const auto k = LaplacianOfGaussian(10);
  ASSERT_EQ(k.size(), 81u);
  EXPECT_DOUBLE_EQ(k[40], -1.0 / 100);  // g''(0) = −1/σ²
  EXPECT_NEAR(k[50], 0.0, 1e-15);       // zero crossings at ±σ
  EXPECT_NEAR(k[30], 0.0, 1e-15);
  // ∫g'' = 0 over the line; truncated at ±4σ the sum is 2·g'(4σ) ≈ −2.7e-4, 3 % of |g''(0)|.
  double sum = 0;
  for (double v : k) sum += v;
  EXPECT_NEAR(sum, 2 * (-4.0 / 10) * std::exp(-8.0), 1e-4);
}

TEST(Refine, ConvolutionMatchesTheDefinition) {
  const std::vector<double> s = {1, 2, 0, -1, 3, 5, 4};
  const std::vector<double> k = {0.5, -1, 0.25};
  const auto c = Convolve(s, k);
  ASSERT_EQ(c.size(), s.size());
  // Interior: c[i] = s[i+1]·k0 + s[i]·k1 + s[i−1]·k2; ends extended by the end value.
  EXPECT_DOUBLE_EQ(c[3], 3 * 0.5 - 1 * -1 + 0 * 0.25 - 0 + 0);
  EXPECT_DOUBLE_EQ(c[3], 3 * 0.5 + (-1) * (-1) + 0 * 0.25);
  EXPECT_DOUBLE_EQ(c[0], 2 * 0.5 + 1 * -1 + 1 * 0.25);
  EXPECT_DOUBLE_EQ(c[6], 4 * 0.5 + 4 * -1 + 5 * 0.25);
}

// A fold standing 2 cm out towards the sensor, 3 cm wide (Gaussian profile), crest at
// x0, 12 cm away, on a sheet 14 cm away; readings with 1 mm Gaussian noise.
std::vector<double> RidgeScan(double x0, const RefineOptions& o, uint64_t seed, double noise = 0.001) {
  Rng rng(seed);
  std::vector<double> r;
  for (int i = -o.half_width_samples; i <= o.half_width_samples; ++i) {
    const double x = i * o.sample_spacing;
    r.push_back(0.14 - 0.02 * std::exp(-(x - x0) * (x - x0) / (2 * 0.03 * 0.03)) + rng.Normal(0, noise));
  }
  return r;
}

TEST(Refine, FindsTheCrestOfAKnownRidge) {
  RefineOptions o;
  for (double x0 : {-0.04, -0.013, 0.0, 0.021, 0.035}) {
    for (uint64_t seed = 1; seed <= 5; ++seed) {
      const RefineResult r = RefineScan(RidgeScan(x0, o, seed), o);
      // Within 8 mm (two samples) of the crest, noise and all.
      EXPECT_TRUE(r.fold_found) << "x0 " << x0 << " seed " << seed;
      EXPECT_NEAR(r.offset, x0, 0.008) << "x0 " << x0 << " seed " << seed;
      EXPECT_NEAR(r.range, 0.12, 0.004);
    }
    // Noise-free: within one sample.
    EXPECT_NEAR(RefineScan(RidgeScan(x0, o, 1, 0.0), o).offset, x0, o.sample_spacing + 1e-12);
  }
}

TEST(Refine, ARidgeBeyondHalfTheGripperOpeningLeavesThePrediction) {
  RefineOptions o;
  ASSERT_DOUBLE_EQ(o.search_half_width_samples * o.sample_spacing, 0.04);
  for (double x0 : {-0.08, -0.06, 0.06, 0.08}) {
    for (uint64_t seed = 1; seed <= 3; ++seed) {
      const RefineResult r = RefineScan(RidgeScan(x0, o, seed, 0.0), o);
      // The response falls all the way out to the crest: no minimum within ±4 cm.
      EXPECT_FALSE(r.fold_found) << "x0 " << x0;
      EXPECT_DOUBLE_EQ(r.offset, 0.0) << "x0 " << x0;
      // The depth still comes from the reading at the prediction.
      EXPECT_DOUBLE_EQ(r.range, RidgeScan(x0, o, seed, 0.0)[o.half_width_samples]);
    }
  }
  // A searched window as wide as the scan finds the far crest again (the rule as first
  // built, the paper's "lowest point" over the whole scan).
  o.search_half_width_samples = o.half_width_samples;
  EXPECT_NEAR(RefineScan(RidgeScan(0.06, o, 1, 0.0), o).offset, 0.06, o.sample_spacing + 1e-12);
}

TEST(Refine, TakesTheFoldWithinReachOverAHigherOneFarther) {
  RefineOptions o;
  // A 2 cm fold 7 cm to one side and a 1 cm fold 2 cm to the other: the far one has the
  // lower response over the whole scan, the near one is what the jaws can reach.
  std::vector<double> r;
  for (int i = -o.half_width_samples; i <= o.half_width_samples; ++i) {
    const double x = i * o.sample_spacing;
    r.push_back(0.14 - 0.02 * std::exp(-(x - 0.07) * (x - 0.07) / (2 * 0.03 * 0.03)) -
                0.01 * std::exp(-(x + 0.02) * (x + 0.02) / (2 * 0.03 * 0.03)));
  }
  const RefineResult res = RefineScan(r, o);
  EXPECT_TRUE(res.fold_found);
  EXPECT_NEAR(res.offset, -0.02, 0.008);
  EXPECT_LT(*std::min_element(res.response.begin() + 30, res.response.end()), res.response[res.best]);
}

TEST(Refine, PrefersAGripperWideFoldToANarrowSpike) {
  RefineOptions o;
  std::vector<double> r = RidgeScan(0.03, o, 3);
  // A 1-sample spike 3 cm out at −3.2 cm: nearer than the fold, but not graspable.
  r[o.half_width_samples - 8] = 0.11;
  EXPECT_NEAR(RefineScan(r, o).offset, 0.03, 0.008);
}

TEST(Refine, MissingReadingsAndBadInput) {
  RefineOptions o;
  std::vector<double> r = RidgeScan(0.0, o, 2);
  // The scan runs off the cloth for its first 10 samples: they take the first reading.
  for (int i = 0; i < 10; ++i) r[i] = i % 2 ? 0.0 : std::numeric_limits<double>::infinity();
  const RefineResult res = RefineScan(r, o);
  ASSERT_TRUE(res.valid);
  EXPECT_DOUBLE_EQ(res.height[0], -r[10]);
  EXPECT_DOUBLE_EQ(res.height[9], -r[10]);
  EXPECT_NEAR(res.offset, 0.0, 0.008);
  EXPECT_TRUE(res.measured);
  // Nothing in range at all: not valid, centre.
  const RefineResult none = RefineScan(std::vector<double>(11, std::numeric_limits<double>::infinity()), o);
  EXPECT_FALSE(none.valid);
  EXPECT_EQ(none.best, 5);
  EXPECT_THROW(RefineScan({}, o), Error);
  o.sample_spacing = 0;
  EXPECT_THROW(RefineScan(r, o), Error);
  o = RefineOptions();
  o.search_half_width_samples = o.half_width_samples + 1;
  EXPECT_THROW(RefineScan(r, o), Error);
}

TEST(Refine, DepthFromTheNearestReadingTheJawsSpan) {
  // A sleeve 18 cm away whose edge lies 1 sample left of the centre; beyond it the beam
  // reads the body behind, 36 cm away. Centre only (no search).
  RefineOptions o;
  o.search_half_width_samples = 0;
  std::vector<double> r(2 * o.half_width_samples + 1, 0.36);
  for (int i = 0; i < o.half_width_samples; ++i) r[i] = 0.18 + 0.001 * i;  // up to 0.204 at the edge
  const RefineResult own = RefineScan(r, o);
  EXPECT_EQ(own.best, o.half_width_samples);
  EXPECT_DOUBLE_EQ(own.range, 0.36);  // the body behind the sleeve
  o.depth_half_width_samples = 5;     // ±2 cm
  const RefineResult near = RefineScan(r, o);
  EXPECT_EQ(near.best, o.half_width_samples);  // the grasp stays at the centre across the scan
  EXPECT_DOUBLE_EQ(near.offset, 0.0);
  EXPECT_NEAR(near.range, 0.18 + 0.001 * (o.half_width_samples - 5), 1e-12);  // the sleeve
  EXPECT_TRUE(near.measured);
  o.depth_half_width_samples = o.half_width_samples + 1;
  EXPECT_THROW(RefineScan(r, o), Error);
}

// A vertical scan (top to bottom) of a sheet whose lower edge is `edge` m above the refined
// point (negative: below), leaning 10 % away from the sensor, 12 cm from it at the refined
// point's height; below the edge the beam reads `behind` (+inf: nothing). 1 mm noise.
std::vector<double> HemScan(double edge, double behind, const EdgeOptions& o, uint64_t seed) {
  Rng rng(seed);
  std::vector<double> r;
  for (int i = 0; i <= o.above_samples + o.below_samples; ++i) {
    const double h = (o.above_samples - i) * o.sample_spacing;
    r.push_back(h >= edge - 1e-9 ? 0.12 + 0.1 * h + 0.001 * rng.Normal() : behind);
  }
  return r;
}

TEST(Edge, FindsTheHemBelowAndGraspsInsetAboveIt) {
  EdgeOptions o;
  const double inf = std::numeric_limits<double>::infinity();
  for (double behind : {inf, 0.30, 0.0}) {
    const EdgeResult e = FindLowerEdge(HemScan(-0.062, behind, o, 7), 0.12, o);
    ASSERT_TRUE(e.found) << behind;
    EXPECT_EQ(e.start, o.above_samples);
    // The lowest reading of the sheet is at −6.0 cm (samples every 4 mm); 1 cm above it.
    EXPECT_NEAR((o.above_samples - e.edge) * o.sample_spacing, -0.060, 1e-9);
    EXPECT_NEAR(e.up, -0.060 + 0.012, 1e-9);  // inset 1 cm: 2.5 samples, rounded to 3
    EXPECT_NEAR(e.range, 0.12 + 0.1 * e.up, 0.005);
  }
}

TEST(Edge, FindsTheHemAboveWhenThePointIsBelowTheCloth) {
  EdgeOptions o;
  // The refined point is 5 cm below the hem, in the air: by default nothing is looked for
  // above it (no change) ...
  EXPECT_FALSE(FindLowerEdge(HemScan(0.05, std::numeric_limits<double>::infinity(), o, 3), 0.12, o).found);
  // ... with look_above the nearest surface sample is the hem itself (reference range
  // 12 cm, read there 12.5 cm), and the grasp goes up.
  o.look_above = true;
  const EdgeResult e = FindLowerEdge(HemScan(0.05, std::numeric_limits<double>::infinity(), o, 3), 0.12, o);
  ASSERT_TRUE(e.found);
  EXPECT_EQ(e.start, e.edge);
  EXPECT_NEAR(e.up, 0.052 + 0.012, 1e-9);
  // A surface farther than `near` from the reference is another layer: nothing found.
  EXPECT_FALSE(FindLowerEdge(HemScan(0.05, std::numeric_limits<double>::infinity(), o, 3), 0.06, o).found);
}

// A fold's lower edge just above the refined point, a gap, then the hem 6 cm further
// down: the hem below by default; the fold's edge above with look_above (as first built).
TEST(Edge, LooksBelowTheRefinedPointByDefault) {
  EdgeOptions o;
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> r(o.above_samples + o.below_samples + 1, inf);
  for (int i = 0; i < o.above_samples; ++i) r[i] = 0.12;                          // the fold, down to +4 mm
  for (int i = o.above_samples + 3; i <= o.above_samples + 15; ++i) r[i] = 0.13;  // the leg, -1.2 to -6 cm
  const EdgeResult down = FindLowerEdge(r, 0.12, o);
  ASSERT_TRUE(down.found);
  EXPECT_EQ(down.start, o.above_samples + 3);
  EXPECT_EQ(down.edge, o.above_samples + 15);
  EXPECT_NEAR(down.up, -0.060 + 0.012, 1e-9);
  o.look_above = true;
  const EdgeResult up = FindLowerEdge(r, 0.12, o);
  ASSERT_TRUE(up.found);
  EXPECT_EQ(up.edge, o.above_samples - 1);
  EXPECT_GT(up.up, 0);
}

TEST(Edge, NoEdgeWhenTheSheetGoesOnBelowTheScan) {
  EdgeOptions o;
  const EdgeResult e = FindLowerEdge(HemScan(-1.0, 0.3, o, 5), 0.12, o);
  EXPECT_FALSE(e.found);
  EXPECT_EQ(e.start, o.above_samples);
  // A step of more than `jump` in the surface ends the run: a fold's lower edge in front of
  // the cloth behind it is an edge too (the jaws go to the near layer's).
  std::vector<double> r = HemScan(-1.0, 0.3, o, 5);
  for (size_t i = o.above_samples + 10; i < r.size(); ++i) r[i] += 0.05;
  const EdgeResult f = FindLowerEdge(r, 0.12, o);
  ASSERT_TRUE(f.found);
  EXPECT_EQ(f.edge, o.above_samples + 9);
  EXPECT_THROW(FindLowerEdge(std::vector<double>(5, 0.1), 0.12, o), Error);
  o.near = 0;
  EXPECT_THROW(FindLowerEdge(HemScan(-1.0, 0.3, EdgeOptions{}, 5), 0.12, o), Error);
}

// A 20 × 20 cm sheet in the x-y plane, vertices every 1 cm (y up; vertex j * kSheetSide + i
// at x = i cm, y = j cm), bottom row at y = 0. Vertices only: the edge tests read no faces.
constexpr int kSheetSide = 21;
TriMesh Sheet() {
  TriMesh m;
  m.V.resize(kSheetSide * kSheetSide, 3);
  for (int j = 0; j < kSheetSide; ++j)
    for (int i = 0; i < kSheetSide; ++i) m.V.row(j * kSheetSide + i) = Eigen::RowVector3d(0.01 * i, 0.01 * j, 0);
  return m;
}

TEST(Edge, AnchorAtTheBottomOfAHangingSheet) {
  TriMesh m = Sheet();
  const int n = kSheetSide;
  EdgeOptions o;
  EXPECT_TRUE(AnchorAtLowerEdge(m, 0 * n + 10, o));    // middle of the bottom edge
  EXPECT_TRUE(AnchorAtLowerEdge(m, 0 * n + 0, o));     // bottom corner
  EXPECT_FALSE(AnchorAtLowerEdge(m, 10 * n + 10, o));  // centre
  EXPECT_FALSE(AnchorAtLowerEdge(m, 10 * n + 0, o));   // middle of a side edge
  EXPECT_FALSE(AnchorAtLowerEdge(m, 20 * n + 10, o));  // top edge: everything around lies below
  // Turned upside down the top edge is the lower one.
  m.V.col(1) = -m.V.col(1);
  EXPECT_TRUE(AnchorAtLowerEdge(m, 20 * n + 10, o));
  EXPECT_FALSE(AnchorAtLowerEdge(m, 0 * n + 10, o));
}

TEST(Edge, ScanPlanMovesTheBeamLineUp) {
  IrScanPlan p;
  p.predicted = Vec3(0.1, 1.2, 0.3);
  p.approach = Vec3(0, 0, -1);
  p.closing = Vec3::UnitY().cross(p.approach).normalized();
  p.mount = Vec3(0, 0.03, -0.06);
  EXPECT_TRUE(p.JawDuringScan(0.02, 0.05).isApprox(p.JawDuringScan(0.02) + Vec3(0, 0.05, 0)));
  RefineResult r;
  r.offset = 0.02;
  r.range = 0.17;
  EXPECT_TRUE(p.Grasp(0.02, 0.0, 0.17).isApprox(p.Grasp(r)));
  EXPECT_TRUE(p.Grasp(0.02, -0.04, 0.17).isApprox(p.Grasp(r) - Vec3(0, 0.04, 0)));
}

// A horizontal scan at the jaws' height across a hem 18 cm wide from −11 to +7 cm, 12 cm
// away, cloth 30 cm away beyond both ends; readings 4 mm apart, 1 mm noise.
std::vector<double> SideScan(double from, double to, uint64_t seed) {
  Rng rng(seed);
  std::vector<double> r;
  for (int i = -25; i <= 25; ++i) {
    const double x = i * 0.004;
    r.push_back((x >= from - 1e-9 && x <= to + 1e-9 ? 0.12 : 0.30) + 0.001 * rng.Normal());
  }
  return r;
}

TEST(Edge, FindsTheHemsEndOnTheNamedSide) {
  EdgeOptions o;
  const std::vector<double> r = SideScan(-0.11, 0.068, 4);
  // +1: the end at +6.8 cm, 2 cm in from it.
  const SideResult p = FindSideEdge(r, 0.12, +1, 0.004, o);
  ASSERT_TRUE(p.found);
  EXPECT_NEAR(p.offset, 0.068 - 0.02, 1e-9);
  EXPECT_NEAR(p.range, 0.12, 0.005);
  // −1: the hem goes on past the scan's start (−10 cm): not found.
  EXPECT_FALSE(FindSideEdge(r, 0.12, -1, 0.004, o).found);
  const SideResult m = FindSideEdge(SideScan(-0.052, 0.2, 5), 0.12, -1, 0.004, o);
  ASSERT_TRUE(m.found);
  EXPECT_NEAR(m.offset, -0.052 + 0.02, 1e-9);
  EXPECT_THROW(FindSideEdge(r, 0.12, 0, 0.004, o), Error);
  EXPECT_THROW(FindSideEdge(std::vector<double>(4, 0.1), 0.12, 1, 0.004, o), Error);
}

TEST(Edge, CornerSideFromTheClothAround) {
  // The sheet seen along −z: closing along x.
  TriMesh m = Sheet();
  const int n = kSheetSide;
  EdgeOptions o;
  EXPECT_EQ(CornerSide(m, 0, Vec3::UnitX(), o), -1);       // bottom-left corner: cloth at +x
  EXPECT_EQ(CornerSide(m, n - 1, Vec3::UnitX(), o), 1);    // bottom-right corner
  EXPECT_EQ(CornerSide(m, n - 1, -Vec3::UnitX(), o), -1);  // the same, closing the other way
  EXPECT_EQ(CornerSide(m, 10, Vec3::UnitX(), o), 0);       // middle of the hem
  // Seen edge-on (closing along z): no side.
  EXPECT_EQ(CornerSide(m, 0, Vec3::UnitZ(), o), 0);
}

}  // namespace
}  // namespace drape::unfolding
