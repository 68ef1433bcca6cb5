#include "common/timing.h"

#include <gtest/gtest.h>

namespace drape {
namespace {

using namespace std::chrono_literals;

TEST(Since, IsNonNegativeAndMonotone) {
  const auto t0 = Clock::now();
  const double a = Since(t0);
  const double b = Since(t0);
  const double c = Since(t0);
  EXPECT_GE(a, 0.0);
  EXPECT_LE(a, b);
  EXPECT_LE(b, c);
}

TEST(Since, CountsSecondsFromAnEarlierTime) {
  // Units and sign without a timing threshold: a start 2 s back is at least 2 s ago
  // (and nowhere near 2000, which milliseconds would give); a start in the future is negative.
  const double two = Since(Clock::now() - 2s);
  EXPECT_GE(two, 2.0);
  EXPECT_LT(two, 1000.0);
  EXPECT_LT(Since(Clock::now() + 1h), 0.0);
}

TEST(Seconds, IsTheSignedDifferenceInSeconds) {
  const auto t0 = Clock::now();
  EXPECT_EQ(Seconds(t0, t0), 0.0);
  EXPECT_DOUBLE_EQ(Seconds(t0, t0 + 1500ms), 1.5);
  EXPECT_DOUBLE_EQ(Seconds(t0 + 2s, t0), -2.0);
}

}  // namespace
}  // namespace drape
