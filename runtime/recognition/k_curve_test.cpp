// The K curve against a brute-force reference: every query's nearest entry of its
// category among each anchor's first K' hangs, by Eq. match written out bit by bit.
#include "runtime/recognition/k_curve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <climits>

#include "runtime/recognition/test_features.h"

namespace drape::recognition {
namespace {

TEST(KCurve, LevelsDoubleUpToK) {
  EXPECT_EQ(KCurveLevels(1), (std::vector<int>{1}));
  EXPECT_EQ(KCurveLevels(2), (std::vector<int>{1, 2}));
  EXPECT_EQ(KCurveLevels(4), (std::vector<int>{1, 2, 4}));
  EXPECT_EQ(KCurveLevels(6), (std::vector<int>{1, 2, 4, 6}));
}

// Eq. match by brute force: min over rotations k of the bits where Rotate(a, k) and b differ.
int BruteDistance(const Code& a, const Code& b) {
  int best = INT_MAX;
  for (int k = 0; k < a.sectors; ++k) {
    const Code r = Rotate(a, k);
    int d = 0;
    for (int bit = 0; bit < r.NumBits(); ++bit) d += r.Get(bit) != b.Get(bit);
    best = std::min(best, d);
  }
  return best;
}

// The database entry nearest to `q` among `db`'s entries with hang < k (of `category`, or
// of any category when empty); ties: the first.
int BruteNearest(const std::vector<LabelledCode>& db, const Code& q, int k, const std::string& category) {
  int best = -1, best_d = INT_MAX;
  for (size_t i = 0; i < db.size(); ++i) {
    if (db[i].label.hang >= k || (!category.empty() && db[i].label.category != category)) continue;
    const int d = BruteDistance(db[i].code, q);
    if (d < best_d) best = static_cast<int>(i), best_d = d;
  }
  return best;
}

bool TwinOrSame(const std::string& truth, const std::string& predicted) {
  if (truth == predicted) return true;
  const auto twins = SymmetryTwins(truth);
  return std::find(twins.begin(), twins.end(), predicted) != twins.end();
}

// Two categories, anchors with left/right twins, 4 hangs per anchor as far apart as other
// anchors (independent codes), one query per hang (its code with a few bits flipped, turned
// by random sectors): at K' = 1 only hang 0's queries find their anchor, at K' = 4 all do.
// Every level's strict, twin-credited and category accuracy equals the brute force's, and
// the database holds K' hangs per anchor.
TEST(KCurve, MatchesBruteForceNearestOverEachAnchorsFirstHangs) {
  Rng rng(45);
  const std::vector<std::pair<std::string, std::vector<std::string>>> garments = {
      {"shirt", {"left_cuff", "right_cuff", "collar"}}, {"pants", {"left_leg", "right_leg"}}};
  std::vector<LabelledCode> train;
  std::vector<EvalQuery> queries;
  for (const auto& [category, anchors] : garments) {
    for (const std::string& anchor : anchors) {
      for (int hang = 0; hang < 4; ++hang) {
        const std::string id = category + "/" + anchor + "/h" + std::to_string(hang);
        train.push_back(Labelled(id, category, category + "-1", anchor, RandomCode(rng, 4, 4, 8)));
        train.back().label.hang = hang;
        queries.emplace_back().query = Labelled(id + "/q", category, category + "-q", anchor,
                                                Rotate(FlipBits(train.back().code, rng, 8), int(rng.Below(8))));
      }
    }
  }
  const Database db(train);
  ASSERT_EQ(HangsPerAnchor(db), 4);
  EXPECT_EQ(FirstHangs(db, 2).size(), 10);
  const EvalResult full = Evaluate(db, nullptr, queries, {}, {});
  const std::vector<KPoint> points = KCurvePoints(db, nullptr, queries, {}, {}, full);
  ASSERT_EQ(points.size(), 3u);
  const Json table = KCurveTable(points);
  EXPECT_EQ(table["hangs_per_anchor"], 4);
  std::vector<int> brute_strict;
  for (size_t l = 0; l < points.size(); ++l) {
    const int k = points[l].hangs;
    EXPECT_EQ(points[l].database_entries, 5 * k);
    int strict = 0, twin = 0, category = 0;
    for (const EvalQuery& q : queries) {
      const LabelledCode& pose = train[BruteNearest(train, q.query.code, k, q.query.label.category)];
      strict += pose.label.anchor == q.query.label.anchor;
      twin += TwinOrSame(q.query.label.anchor, pose.label.anchor);
      category += train[BruteNearest(train, q.query.code, k, "")].label.category == q.query.label.category;
    }
    brute_strict.push_back(strict);
    const Json& all = table["levels"][l]["categories"]["all"];
    const double n = queries.size();
    EXPECT_EQ(table["levels"][l]["hangs"], k);
    EXPECT_DOUBLE_EQ(all["strict"]["unweighted"].get<double>(), strict / n) << "K' = " << k;
    EXPECT_DOUBLE_EQ(all["twin_credited"]["unweighted"].get<double>(), twin / n) << "K' = " << k;
    EXPECT_DOUBLE_EQ(all["category_accuracy"].get<double>(), category / n) << "K' = " << k;
  }
  EXPECT_LT(brute_strict.front(), brute_strict.back()) << "the fixture must tell the levels apart";
  const std::string md = KCurveMarkdown(table);
  EXPECT_NE(md.find("| hangs per anchor | database entries | queries | pants | shirt | all | category |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| 4 | 20 | 20 | 100.0 % / 100.0 % | 100.0 % / 100.0 % | 100.0 % / 100.0 % | 100.0 % |"),
            std::string::npos)
      << md;
}

// A database of one hang per anchor has no curve.
TEST(KCurve, NoCurveWithOneHangPerAnchor) {
  Rng rng(1);
  const Database db({Labelled("a", "towel", "towel-1", "top_left", RandomCode(rng, 4, 4, 8))});
  std::vector<EvalQuery> qs(1);
  qs[0].query = Labelled("q", "towel", "towel-q", "top_left", RandomCode(rng, 4, 4, 8));
  const EvalResult full = Evaluate(db, nullptr, qs, {}, {});
  EXPECT_EQ(HangsPerAnchor(db), 1);
  EXPECT_TRUE(KCurvePoints(db, nullptr, qs, {}, {}, full).empty());
}

}  // namespace
}  // namespace drape::recognition
