#include "runtime/unfolding/loop.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace drape::unfolding {
namespace {

// A recognition whose ranked anchors are `anchors`, best first.
recognition::Recognition Ranked(const std::vector<std::string>& anchors) {
  recognition::Recognition r;
  for (size_t i = 0; i < anchors.size(); ++i) {
    recognition::Candidate c;
    c.entry = static_cast<int>(i);
    c.anchor = anchors[i];
    r.top.push_back(c);
  }
  r.anchor = anchors.front();
  r.best = r.top.front();
  return r;
}

TEST(PlanPrior, KeepsTheAimedAnchorOrItsTwinWithinTheTopK) {
  // The trouser-leg case of the paper release: a hang from a leg's outer corner is ranked
  // behind both inner corners.
  const auto r = Ranked({"left_leg_inner", "right_leg_inner", "right_leg_outer", "crotch"});
  EXPECT_EQ(PlanPriorRank(r, "right_leg_outer", 3), 2);
  EXPECT_EQ(PlanPriorRank(r, "left_leg_outer", 3), 2);  // its twin
  EXPECT_EQ(PlanPriorRank(r, "left_leg_inner", 3), 0);
  EXPECT_EQ(PlanPriorRank(r, "right_leg_outer", 2), -1);  // beyond k: recognition's answer
  EXPECT_EQ(PlanPriorRank(r, "crotch", 3), -1);
  EXPECT_EQ(PlanPriorRank(r, "crotch", 5), 3);
  EXPECT_EQ(PlanPriorRank(r, "waist_center", 5), -1);            // not ranked at all
  EXPECT_EQ(PlanPriorRank(r, "left_leg_inner", 0), -1);          // off: the paper's afresh
  EXPECT_EQ(PlanPriorRank(r, "", 3), -1);                        // first step: nothing aimed
  EXPECT_EQ(PlanPriorRank(Ranked({"collar"}), "collar", 3), 0);  // fewer ranked than k
}

}  // namespace
}  // namespace drape::unfolding
