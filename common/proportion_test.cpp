#include "common/proportion.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"

namespace drape {
namespace {

// Reference values: the closed form evaluated independently (Python, double precision).
TEST(Proportion, WilsonIntervalMatchesPublishedValues) {
  Proportion a = WilsonInterval(5, 10);
  EXPECT_NEAR(a.low, 0.2365931, 1e-6);
  EXPECT_NEAR(a.high, 0.7634069, 1e-6);
  Proportion b = WilsonInterval(0, 10);
  EXPECT_EQ(b.low, 0.0);
  EXPECT_NEAR(b.high, 0.2775328, 1e-6);
  Proportion c = WilsonInterval(10, 10);
  EXPECT_NEAR(c.low, 0.7224672, 1e-6);
  EXPECT_EQ(c.high, 1.0);
}

// The interval is the set of p whose score test accepts k: at its ends the score
// statistic (p̂ − p)/√(p(1 − p)/n) is exactly ±z, brute force on a fine grid agrees.
TEST(Proportion, WilsonIntervalIsTheScoreTestsAcceptanceRegion) {
  for (int n : {1, 8, 19, 39}) {
    for (int k = 0; k <= n; ++k) {
      const Proportion w = WilsonInterval(k, n);
      double lo = 2, hi = -1;
      for (int i = 1; i < 200000; ++i) {
        const double p = i / 200000.0, ph = double(k) / n;
        if (std::abs(ph - p) <= kZ95 * std::sqrt(p * (1 - p) / n)) lo = std::min(lo, p), hi = std::max(hi, p);
      }
      if (k == 0) lo = 0;
      if (k == n) hi = 1;
      EXPECT_NEAR(w.low, lo, 1e-5) << k << "/" << n;
      EXPECT_NEAR(w.high, hi, 1e-5) << k << "/" << n;
    }
  }
}

TEST(Proportion, DifferenceBeyondChanceAndTheTrialsItNeeds) {
  // Two runs of 19 queries at 50 %: 1.96·√(0.5/19) = 31.8 points.
  EXPECT_NEAR(DifferenceBeyondChance(0.5, 19), 0.3179, 1e-4);
  // 5 points at 50 % needs 2·1.96²·0.25/0.0025 = 768.3 → 769 queries per run.
  EXPECT_EQ(TrialsForDifference(0.5, 0.05), 769);
  EXPECT_LE(DifferenceBeyondChance(0.5, TrialsForDifference(0.5, 0.05)), 0.05);
  EXPECT_GT(DifferenceBeyondChance(0.5, TrialsForDifference(0.5, 0.05) - 1), 0.05);
  EXPECT_EQ(DifferenceBeyondChance(1.0, 10), 0.0);
  EXPECT_EQ(TrialsForDifference(1.0, 0.05), 1);
}

TEST(Proportion, BadCountsAreErrors) {
  EXPECT_THROW(WilsonInterval(3, 2), Error);
  EXPECT_THROW(WilsonInterval(-1, 2), Error);
  EXPECT_THROW(WilsonInterval(0, 0), Error);
  EXPECT_THROW(DifferenceBeyondChance(0.5, 0), Error);
  EXPECT_THROW(TrialsForDifference(0.5, 0), Error);
}

}  // namespace
}  // namespace drape
