// The category over a trial's hangs (category.h) from hand-made scores.
#include "runtime/unfolding/category.h"

#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace drape::unfolding {
namespace {

TEST(SummedFitCategory, TheLeastSumOverHangsAndAnAbsentCategoryCountsTheHangsWorst) {
  using Scores = std::map<std::string, double>;
  EXPECT_EQ(SummedFitCategory({}, "pants"), "");
  // One hang: its best fit.
  EXPECT_EQ(SummedFitCategory({Scores{{"pants", 0.017}, {"shirt", 0.022}}}, ""), "pants");
  // A second hang that tells the shirt clearly outweighs the first's small margin.
  const std::vector<Scores> two = {{{"pants", 0.017}, {"shirt", 0.022}}, {{"pants", 0.030}, {"shirt", 0.012}}};
  EXPECT_EQ(SummedFitCategory(two, "pants"), "shirt");  // 0.047 against 0.034
  // Shorts took part at the second hang only, pants at the first only: each counts the
  // other hang's worst. Shorts 0.022 + 0.005 = 0.027, pants 0.017 + 0.012 = 0.029, shirt 0.034.
  const std::vector<Scores> three = {{{"pants", 0.017}, {"shirt", 0.022}}, {{"shorts", 0.005}, {"shirt", 0.012}}};
  EXPECT_EQ(SummedFitCategory(three, "shirt"), "shorts");
  const std::vector<Scores> three_b = {{{"pants", 0.017}, {"shirt", 0.022}}, {{"shorts", 0.010}, {"shirt", 0.012}}};
  EXPECT_EQ(SummedFitCategory(three_b, "shirt"), "pants");  // 0.029 against shorts 0.032
  // Ties keep the standing category.
  const std::vector<Scores> tie = {{{"pants", 0.02}, {"shirt", 0.02}}};
  EXPECT_EQ(SummedFitCategory(tie, "shirt"), "shirt");
  EXPECT_EQ(SummedFitCategory(tie, "pants"), "pants");
}

TEST(SummedFitCategory, ACategoryLeftOutOfAHangCountsItsWorstPlusThePenalty) {
  using Scores = std::map<std::string, double>;
  // The first hang passed the gate of shorts alone; at the second a shirt fits 18 % better.
  const std::vector<Scores> hangs = {{{"shorts", 1.0}}, {{"shirt", 1.0}, {"shorts", 1.18}}};
  // Without a penalty the shirt counts 1.0 at the first hang, as the shorts: 2.0 < 2.18.
  EXPECT_EQ(SummedFitCategory(hangs, "shorts"), "shirt");
  EXPECT_EQ(SummedFitCategory(hangs, "shorts", 0.0), "shirt");
  // Left out, it counts 1.0 + 0.25 there: 2.25 > 2.18, the shorts stay.
  EXPECT_EQ(SummedFitCategory(hangs, "shorts", 0.25), "shorts");
  // A later hang that tells the shirt clearly still switches.
  std::vector<Scores> three = hangs;
  three.push_back({{"shirt", 1.0}, {"shorts", 1.4}});
  EXPECT_EQ(SummedFitCategory(three, "shorts", 0.25), "shirt");  // 3.25 against 3.58
  // Categories that took part at every hang are not touched by the penalty.
  const std::vector<Scores> both = {{{"pants", 1.0}, {"shirt", 1.2}}, {{"pants", 1.3}, {"shirt", 1.0}}};
  EXPECT_EQ(SummedFitCategory(both, "pants", 0.0), SummedFitCategory(both, "pants", 5.0));
  EXPECT_THROW(SummedFitCategory(hangs, "shorts", -0.1), std::logic_error);
}

}  // namespace
}  // namespace drape::unfolding
