// The category from every hang (category.h): one hang's evidence from Eq. match, and the
// accumulated decision over hand-made hangs.
#include "runtime/unfolding/category.h"

#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "runtime/recognition/test_features.h"
#include "runtime/unfolding/objective.h"

namespace drape::unfolding {
namespace {

namespace rec = drape::recognition;

// A hang's evidence with these excesses (category → e_c); the nearest has the least.
HangEvidence Hang(const std::vector<std::pair<std::string, double>>& excess) {
  HangEvidence e;
  e.bits = 4096;
  double best = 1e9;
  for (const auto& [c, x] : excess) {
    HangEvidence::PerCategory pc;
    pc.category = c;
    pc.excess = x;
    e.categories.push_back(pc);
    if (x < best) best = x, e.nearest = c;
  }
  return e;
}

TEST(CategoryDecision, TheFirstHangDecidesAsRecognitionDoes) {
  CategoryDecision d;
  EXPECT_FALSE(d.Add(Hang({{"long_sleeve_shirt", 0}, {"pants", 0.004}, {"shorts", 0.02}})));
  EXPECT_EQ(d.decided(), "long_sleeve_shirt");
  EXPECT_EQ(d.hangs(), 1);
  // A tie at the first hang goes to the hang's nearest (recognition's tie rule), not to
  // the first name.
  HangEvidence tie = Hang({{"long_sleeve_shirt", 0}, {"pants", 0}});
  tie.nearest = "pants";
  CategoryDecision t;
  t.Add(tie);
  EXPECT_EQ(t.decided(), "pants");
}

TEST(CategoryDecision, LaterHangsOverruleAFirstHangThatWasNarrowlyWrong) {
  // Pants taken for a shirt at the random first grasp by a small margin; the hangs after
  // aimed regrasps say pants by more.
  CategoryDecision d;
  d.Add(Hang({{"long_sleeve_shirt", 0}, {"pants", 0.006}, {"shorts", 0.03}}));
  EXPECT_FALSE(d.Add(Hang({{"long_sleeve_shirt", 0.004}, {"pants", 0}, {"shorts", 0.02}})));
  EXPECT_EQ(d.decided(), "long_sleeve_shirt");  // 0.004 against 0.006: not yet
  EXPECT_NEAR(d.totals().at("pants"), 0.006, 1e-12);
  EXPECT_NEAR(d.totals().at("long_sleeve_shirt"), 0.004, 1e-12);
  EXPECT_TRUE(d.Add(Hang({{"long_sleeve_shirt", 0.005}, {"pants", 0}, {"shorts", 0.02}})));
  EXPECT_EQ(d.decided(), "pants");  // 0.009 against 0.006
  // One more hang that leans the other way, not enough to switch back.
  EXPECT_FALSE(d.Add(Hang({{"long_sleeve_shirt", 0}, {"pants", 0.002}, {"shorts", 0.02}})));
  EXPECT_EQ(d.decided(), "pants");
}

TEST(CategoryDecision, TiesKeepTheDecisionStandingAndWeightsScaleAHang) {
  CategoryDecision d;
  d.Add(Hang({{"pants", 0}, {"shorts", 0.01}}));
  EXPECT_FALSE(d.Add(Hang({{"pants", 0.01}, {"shorts", 0}})));  // 0.01 each
  EXPECT_EQ(d.decided(), "pants");
  // A weightless first hang: the second alone decides.
  CategoryDecision w;
  w.Add(Hang({{"pants", 0}, {"shorts", 0.05}}), 0.0);
  EXPECT_EQ(w.decided(), "pants");
  EXPECT_TRUE(w.Add(Hang({{"pants", 0.001}, {"shorts", 0}})));
  EXPECT_EQ(w.decided(), "shorts");
}

TEST(CategoryDecision, ASwitchRePlansWithTheNewCategorysDesiredPairs) {
  // What the loop plans with after the switch: the desired pair of the decided category.
  CategoryDecision d;
  d.Add(Hang({{"long_sleeve_shirt", 0}, {"pants", 0.001}}));
  EXPECT_EQ(DesiredPairsFor(d.decided()).front().first, "left_elbow");
  ASSERT_TRUE(d.Add(Hang({{"long_sleeve_shirt", 0.01}, {"pants", 0}})));
  const std::vector<DesiredPair> pairs = DesiredPairsFor(d.decided());
  ASSERT_FALSE(pairs.empty());
  EXPECT_EQ(pairs.front().first, "left_leg_outer");
  EXPECT_EQ(pairs.front().second, "right_leg_outer");
}

// Two categories with distinct shapes; the query is a noisy copy of one entry.
struct TwoCategories {
  Rng rng{11};
  rec::Code shirt = rec::RandomCode(rng, 4, 4, 8), pants = rec::RandomCode(rng, 4, 4, 8),
            pants_waist = rec::RandomCode(rng, 4, 4, 8);
  rec::Database db;
  TwoCategories() {
    std::vector<rec::LabelledCode> v;
    v.push_back(rec::Labelled("s0", "long_sleeve_shirt", "shirt-1", "left_elbow", shirt, 0.9));
    v.push_back(rec::Labelled("p0", "pants", "pants-1", "left_leg_outer", pants, 1.5));
    v.push_back(rec::Labelled("p1", "pants", "pants-1", "waist_center", pants_waist, 1.3));
    db = rec::Database(std::move(v));
  }
  std::vector<rec::Match> Match(const rec::Code& q) const {
    std::vector<rec::Match> m;
    db.matcher().MatchAll(rec::PreparedQuery(q), &m);
    return m;
  }
};

TEST(HangEvidence, ExcessOverTheNearestCategoryInBitsOfTheCode) {
  TwoCategories t;
  const rec::Code q = rec::FlipBits(t.pants, t.rng, 6);
  const std::vector<rec::Match> m = t.Match(q);
  const HangEvidence e = EvidenceOfHang(t.db, m, 0, 0);  // no gate
  EXPECT_EQ(e.nearest, "pants");
  EXPECT_EQ(e.bits, 128);
  ASSERT_EQ(e.categories.size(), 2u);
  EXPECT_EQ(e.categories[0].category, "long_sleeve_shirt");  // sorted by name
  EXPECT_EQ(e.categories[1].category, "pants");
  EXPECT_EQ(e.categories[1].distance, std::min(m[1].distance, m[2].distance));
  EXPECT_LE(e.categories[1].distance, 6);
  EXPECT_EQ(e.categories[1].excess, 0);
  EXPECT_EQ(e.categories[0].distance, m[0].distance);
  const double x = double(m[0].distance - e.categories[1].distance) / 128;
  EXPECT_DOUBLE_EQ(e.categories[0].gated_excess, x);
  EXPECT_DOUBLE_EQ(e.categories[0].ungated_excess, x);  // no gate: the same pool
  EXPECT_DOUBLE_EQ(e.categories[0].excess, 2 * x);      // g + 1 × u
  EXPECT_DOUBLE_EQ(EvidenceOfHang(t.db, m, 0, 0, kGatedOutExcess, 0.5).categories[0].excess, 1.5 * x);
  // Recognition's category decision from the same matches names the same category.
  const rec::Recognizer r(t.db, nullptr);
  rec::RecognizeOptions o;
  o.weighted = false;
  EXPECT_EQ(r.Rank(rec::PreparedQuery(q), m, o).category, e.nearest);
}

TEST(HangEvidence, ACategoryGatedOutIsNeverNearerThanTheFarthestInThePool) {
  TwoCategories t;
  // The shirt's shape, at the pants' height: the category gate (0.3) keeps the pants
  // entries only, so pants is the hang's nearest category although the shirt matches.
  const rec::Code q = rec::FlipBits(t.shirt, t.rng, 2);
  const std::vector<rec::Match> m = t.Match(q);
  const HangEvidence e = EvidenceOfHang(t.db, m, 1.45, 0.3);
  EXPECT_EQ(e.nearest, "pants");
  EXPECT_EQ(e.categories[0].distance, -1);  // gated out
  EXPECT_EQ(e.categories[0].ungated, m[0].distance);
  EXPECT_EQ(e.categories[1].gated_excess, 0);
  EXPECT_LT(e.categories[0].ungated, e.categories[1].distance);     // the shape alone says shirt
  EXPECT_DOUBLE_EQ(e.categories[0].gated_excess, kGatedOutExcess);  // the height says otherwise
  EXPECT_DOUBLE_EQ(EvidenceOfHang(t.db, m, 1.45, 0.3, 0.2).categories[0].gated_excess, 0.2);
  EXPECT_EQ(e.categories[0].ungated_excess, 0);
  EXPECT_DOUBLE_EQ(e.categories[1].ungated_excess, double(e.categories[1].ungated - e.categories[0].ungated) / 128);
  // Within the gate alone (λ = 0) the decision is pants, recognition's; the shape, 2 bits
  // from the shirt and tens from the pants, outweighs the height (a loop's hang at a
  // height no database hang of its garment has).
  CategoryDecision gated_only, both;
  gated_only.Add(EvidenceOfHang(t.db, m, 1.45, 0.3, kGatedOutExcess, 0));
  EXPECT_EQ(gated_only.decided(), "pants");
  both.Add(e);
  EXPECT_EQ(both.decided(), "long_sleeve_shirt");
  // Held 0.9 m tall, the shirt passes and is nearest.
  const HangEvidence f = EvidenceOfHang(t.db, m, 0.9, 0.3);
  EXPECT_EQ(f.nearest, "long_sleeve_shirt");
  EXPECT_EQ(f.categories[0].excess, 0);
  EXPECT_EQ(f.categories[1].distance, -1);  // neither pants hang is within e^0.3 of 0.9 m
  EXPECT_GT(f.categories[1].gated_excess, 0);
  EXPECT_GT(f.categories[1].excess, f.categories[1].gated_excess);
  EXPECT_EQ(f.ToJson()["per_category"]["pants"]["distance"], nullptr);
}

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
