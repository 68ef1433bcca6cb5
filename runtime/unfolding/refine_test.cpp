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

}  // namespace
}  // namespace drape::unfolding
