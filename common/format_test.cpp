#include "common/format.h"

#include <gtest/gtest.h>

#include <limits>

namespace drape {
namespace {

TEST(FormatNumber, WritesNumbersAsPeopleDo) {
  EXPECT_EQ(FormatNumber(10), "10");
  EXPECT_EQ(FormatNumber(0.1), "0.1");
  EXPECT_EQ(FormatNumber(-2.5), "-2.5");
  EXPECT_EQ(FormatNumber(1e-9), "1e-09");
  EXPECT_EQ(FormatNumber(3600), "3600");
  EXPECT_EQ(FormatNumber(std::numeric_limits<double>::infinity()), "inf");
  // Shortest text that reads back bit for bit.
  for (double x : {0.1 + 0.2, 1.0 / 3, 6.02214076e23, 2.2250738585072014e-308})
    EXPECT_EQ(std::stod(FormatNumber(x)), x) << FormatNumber(x);
}

TEST(FormatFixed, MeasurementsWithTheirDecimals) {
  EXPECT_EQ(FormatFixed(26.787441779777954, 1), "26.8");  // a blow-up's node speed, m/s
  EXPECT_EQ(FormatFixed(2.9, 2), "2.90");
  EXPECT_EQ(FormatFixed(-0.004, 2), "-0.00");
  EXPECT_EQ(FormatFixed(3, 0), "3");
}

}  // namespace
}  // namespace drape
