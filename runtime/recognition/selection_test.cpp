#include "runtime/recognition/selection.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace drape::recognition {
namespace {

int NestedMostRight(const std::vector<std::vector<char>>& ok, std::vector<int>* chosen = nullptr) {
  return NestedLeaveOneOut(
      ok, [](const std::vector<int>& r, int) { return MostRight(r); }, chosen);
}

int NestedOneSe(const std::vector<std::vector<char>>& ok, std::vector<int>* chosen = nullptr) {
  return NestedLeaveOneOut(
      ok, [](const std::vector<int>& r, int n) { return OneStandardError(r, std::vector<bool>(r.size(), true), n); },
      chosen);
}

TEST(Selection, OneStandardErrorTakesTheFirstWithinOneStandardError) {
  // Best 3 of 5 (p 0.6): SE·n = sqrt(0.6·0.4·5) = 1.10, so 2 is within it, 1 is not.
  EXPECT_EQ(OneStandardError({1, 2, 3}, {true, true, true}, 5), 1);
  EXPECT_EQ(OneStandardError({1, 2, 3}, {true, false, true}, 5), 2);
  // 4 of 4 (p 1): no slack, the first of the best.
  EXPECT_EQ(OneStandardError({3, 4, 4}, {true, true, true}, 4), 1);
  EXPECT_EQ(OneStandardError({1, 2}, {false, false}, 5), -1);
  EXPECT_EQ(OneStandardError({1, 2}, {true, true}, 0), -1);
  EXPECT_EQ(MostRight({2, 5, 5, 1}), 1);
  EXPECT_EQ(MostRight({}), -1);
}

TEST(Selection, NestedLeaveOneOutByMostRight) {
  // Setting 0 right on queries 0 and 1, setting 1 on query 2: leaving out query 0 or 1
  // ties the settings 1 to 1 and the first (0) is taken, leaving out 2 takes 0 as well:
  // 2 right, as setting 0 itself.
  std::vector<int> chosen;
  EXPECT_EQ(NestedMostRight({{1, 0}, {1, 0}, {0, 1}}, &chosen), 2);
  EXPECT_EQ(chosen, (std::vector<int>{0, 0, 0}));
  // Each setting right on one query only (luck): leaving a query out makes another
  // setting the best, wrong there: 0 right, against 1 of 3 for any setting in-sample.
  EXPECT_EQ(NestedMostRight({{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, &chosen), 0);
  EXPECT_EQ(chosen, (std::vector<int>{1, 0, 0}));
  EXPECT_EQ(NestedMostRight({}, &chosen), 0);
  EXPECT_TRUE(chosen.empty());
}

TEST(Selection, NestedLeaveOneOutFollowsTheRule) {
  // Five queries, two settings: setting 0 (the simpler) right on query 4 only, setting 1
  // on queries 2, 3 and 4. In-sample both rules take setting 1 (3 of 5; one-SE slack
  // sqrt(0.6·0.4·5) = 1.10 > 3 − 1 is false).
  const std::vector<std::vector<char>> ok{{0, 0}, {0, 0}, {0, 1}, {0, 1}, {1, 1}};
  EXPECT_EQ(OneStandardError({1, 3}, {true, true}, 5), 1);
  // Most right, leaving each query out: counts (1, 3), (1, 3), (1, 2), (1, 2), (0, 2):
  // always setting 1, right on queries 2, 3, 4: 3.
  std::vector<int> chosen;
  EXPECT_EQ(NestedMostRight(ok, &chosen), 3);
  EXPECT_EQ(chosen, (std::vector<int>{1, 1, 1, 1, 1}));
  // One standard error on the other 4 queries: (1, 3) has slack sqrt(0.75·0.25·4) = 0.87,
  // setting 1; (1, 2) has slack sqrt(0.5·0.5·4) = 1, so setting 0 (1 >= 2 − 1), wrong on
  // queries 2 and 3; (0, 2): setting 1, right on query 4. 1 right, not the in-sample 3.
  EXPECT_EQ(NestedOneSe(ok, &chosen), 1);
  EXPECT_EQ(chosen, (std::vector<int>{1, 1, 0, 0, 1}));
  // A rule that chooses none counts the query wrong; rows must be as long.
  EXPECT_EQ(NestedLeaveOneOut(ok, [](const std::vector<int>&, int) { return -1; }), 0);
  EXPECT_THROW(NestedMostRight({{1, 0}, {1}}), Error);
}

}  // namespace
}  // namespace drape::recognition
