#include "runtime/unfolding/objective.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"

namespace drape::unfolding {
namespace {

// A hand-made "garment": two desired points 0.6 m apart and three others.
std::vector<AnchorPoint> Anchors() {
  return {{"left_elbow", Vec2(0.3, 0.5)},
          {"right_elbow", Vec2(-0.3, 0.5)},
          {"collar", Vec2(0.0, 0.7)},
          {"hem_center", Vec2(0.0, 0.0)},
          {"left_cuff", Vec2(0.35, 0.45)}};  // 7.1 cm from left_elbow
}

TEST(Objective, DesiredPairScoresOneAndIsSymmetric) {
  ObjectiveOptions o;
  ScoreTable t(Anchors(), DesiredPairsFor("long_sleeve_shirt"), o);
  const int l = t.IndexOf("left_elbow"), r = t.IndexOf("right_elbow");
  EXPECT_DOUBLE_EQ(t(l, r), 1.0);
  EXPECT_DOUBLE_EQ(t(r, l), 1.0);
  for (int i = 0; i < t.size(); ++i)
    for (int j = 0; j < t.size(); ++j) {
      EXPECT_DOUBLE_EQ(t(i, j), t(j, i));
      EXPECT_LE(t(i, j), 1.0);
      EXPECT_GT(t(i, j), 0.0);
    }
}

TEST(Objective, TableIsTheGaussianOfEqFinalobj) {
  ObjectiveOptions o;
  o.sigma_length = 0.1;  // σ = 50 m⁻²
  ScoreTable t(Anchors(), DesiredPairsFor("long_sleeve_shirt"), o);
  const int c = t.IndexOf("collar"), h = t.IndexOf("hem_center"), r = t.IndexOf("right_elbow");
  // (collar, hem): best assignment collar→left (0.3² + 0.2²) + hem→right (0.3² + 0.5²).
  const double d2 = (0.09 + 0.04) + (0.09 + 0.25);
  EXPECT_NEAR(t(c, h), std::exp(-50 * d2), 1e-15);
  // (collar, right_elbow): collar takes the left point.
  EXPECT_NEAR(t(c, r), std::exp(-50 * 0.13), 1e-15);
  EXPECT_NEAR(t.PointScore(Vec2(0.3, 0.6)), std::exp(-50 * 0.01), 1e-15);
}

TEST(Objective, BestNextMovesTowardsTheDesiredPair) {
  ObjectiveOptions o;
  ScoreTable t(Anchors(), DesiredPairsFor("long_sleeve_shirt"), o);
  // Holding a desired point: the other one, and that reaches ξ.
  auto n = t.BestNext(t.IndexOf("left_elbow"));
  EXPECT_EQ(t.anchor(n.anchor).label, "right_elbow");
  EXPECT_DOUBLE_EQ(n.f, 1.0);
  EXPECT_GE(n.f, o.xi);
  // Holding the hem: a desired point (the table is symmetric in left/right: the first
  // in the garment's order), with f below ξ, so the plan regrasps again.
  n = t.BestNext(t.IndexOf("hem_center"));
  EXPECT_EQ(t.anchor(n.anchor).label, "left_elbow");
  EXPECT_LT(n.f, o.xi);
  // Holding the left cuff (7 cm from the left elbow): the right elbow, f = e^{−50·0.005}.
  n = t.BestNext(t.IndexOf("left_cuff"));
  EXPECT_EQ(t.anchor(n.anchor).label, "right_elbow");
  EXPECT_NEAR(n.f, std::exp(-50 * 0.005), 1e-12);
  // The left elbow is within min_separation of the held cuff: never offered.
  o.min_separation = 0.2;
  ScoreTable wide(Anchors(), DesiredPairsFor("long_sleeve_shirt"), o);
  EXPECT_NE(wide.anchor(wide.BestNext(wide.IndexOf("right_elbow")).anchor).label, "left_cuff");
}

TEST(Objective, TowelTakesAnyTwoAdjacentCorners) {
  std::vector<AnchorPoint> a = {{"top_left", Vec2(-0.15, 0.5)},
                                {"top_right", Vec2(0.15, 0.5)},
                                {"bottom_left", Vec2(-0.15, 0)},
                                {"bottom_right", Vec2(0.15, 0)},
                                {"center", Vec2(0, 0.25)}};
  ScoreTable t(a, DesiredPairsFor("towel"), {});
  EXPECT_DOUBLE_EQ(t(t.IndexOf("top_left"), t.IndexOf("bottom_left")), 1.0);
  EXPECT_DOUBLE_EQ(t(t.IndexOf("bottom_right"), t.IndexOf("bottom_left")), 1.0);
  EXPECT_LT(t(t.IndexOf("top_left"), t.IndexOf("bottom_right")), 0.5);  // diagonal
}

TEST(Objective, BadInputIsAnError) {
  EXPECT_TRUE(DesiredPairsFor("tshirt").empty());
  EXPECT_THROW(ScoreTable(Anchors(), {}, {}), Error);
  EXPECT_THROW(ScoreTable(Anchors(), DesiredPairsFor("pants"), {}), Error);  // no leg anchors
  ObjectiveOptions o;
  o.xi = 0;
  EXPECT_THROW(o.Validate(), Error);
}

}  // namespace
}  // namespace drape::unfolding
