// The category by registration (category_fit.h): the fit overrules a Hamming nearest
// neighbour of the wrong category, the decision rule, and its error handling.
#include "runtime/recognition/category_fit.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"
#include "runtime/recognition/test_features.h"
#include "runtime/registration/test_meshes.h"

namespace drape::recognition {
namespace {

namespace rt = drape::registration::testing;

// A query code, a pants entry 10 bits from it (the Hamming nearest neighbour) and a
// shirt entry 80 bits from it; the query's reconstruction is the shirt's hung shape
// (long and narrow, deformed), the pants' hung shape is wide and short.
struct TwoCategories {
  Database db;
  Code query;
  std::vector<Match> matches;
  TriMesh shirt_hang = rt::FlatTube(24, 18, 0.35, 0.8, 0.06);
  TriMesh pants_hang = rt::FlatTube(24, 18, 0.8, 0.35, 0.06);
  TriMesh recon;
  TwoCategories() {
    Rng rng(7);
    query = RandomCode(rng, 8, 8, 16);
    std::vector<LabelledCode> e;
    e.push_back(Labelled("s", "long_sleeve_shirt", "shirt/i0", "left_cuff", FlipBits(query, rng, 80)));
    e.push_back(Labelled("p", "pants", "pants/i0", "waist_center", FlipBits(query, rng, 10)));
    db = Database(std::move(e));
    db.matcher().MatchAll(PreparedQuery(query), &matches);
    recon = TriMesh{rt::SmoothDeform(shirt_hang.V, 0.01, 5.0), shirt_hang.F};
  }
  std::function<TriMesh(int)> Hung() const {
    return [this](int entry) { return entry == 0 ? shirt_hang : pants_hang; };
  }
};

TEST(CategoryFit, TheFitOverrulesAHammingNearestNeighbourOfTheWrongCategory) {
  const TwoCategories t;
  const std::vector<int> pool = CategoryPool(t.db, 0, 0);
  ASSERT_EQ(pool.size(), 2u);
  ASSERT_EQ(t.db.label(NearestUnweighted(pool, t.matches)).category, "pants");  // the bits are wrong
  CategoryFitOptions o;
  o.per_category = 1;
  const CategoryFit fit = DecideCategoryByFit(t.db, pool, t.matches, t.recon, t.Hung(), o);
  EXPECT_EQ(fit.category, "long_sleeve_shirt");
  ASSERT_EQ(fit.candidates.size(), 2u);
  const FitCandidate& shirt = fit.candidates[0];
  const FitCandidate& pants = fit.candidates[1];
  EXPECT_EQ(shirt.category, "long_sleeve_shirt");
  EXPECT_EQ(pants.category, "pants");
  EXPECT_GE(shirt.fit, 0);
  EXPECT_LT(shirt.fit, 0.5 * pants.fit);
  EXPECT_LT(pants.distance, shirt.distance);
  EXPECT_DOUBLE_EQ(fit.scores.at("long_sleeve_shirt"), 1.0);  // the best fit, λ = 0
  // Weighting the bits heavily gives the nearest neighbour's answer back.
  o.bits_weight = 100;
  EXPECT_EQ(DecideByFit(fit.candidates, o), "pants");
  // Only the nearest category by Hamming considered: the fit has nothing to choose from.
  o.bits_weight = 0;
  o.top_categories = 1;
  EXPECT_EQ(DecideByFit(fit.candidates, o), "pants");
}

FitCandidate Cand(const std::string& category, int distance, double fit) {
  FitCandidate c;
  c.category = category;
  c.distance = distance;
  c.fit = fit;
  return c;
}

TEST(CategoryFit, DecisionUsesEachCategorysFirstEntriesAndSkipsFailures) {
  // By category, then distance (as ChooseFitCandidates lists them).
  const std::vector<FitCandidate> c{Cand("a", 100, 0.030), Cand("a", 110, 0.010), Cand("b", 90, 0.020),
                                    Cand("b", 95, -1)};
  CategoryFitOptions o;
  o.per_category = 1;
  EXPECT_EQ(DecideByFit(c, o), "b");  // a's first entry fits worse than b's
  o.per_category = 2;
  std::map<std::string, double> scores;
  EXPECT_EQ(DecideByFit(c, o, &scores), "a");  // a's second entry fits best
  EXPECT_DOUBLE_EQ(scores.at("a"), 1.0);
  EXPECT_DOUBLE_EQ(scores.at("b"), 2.0);
  // λ: score = fit / min fit + λ · d / min d; a: 1 + λ·100/90, b: 2 + λ.
  o.bits_weight = 10;
  EXPECT_EQ(DecideByFit(c, o), "b");
  // No usable fit at all: no decision.
  EXPECT_EQ(DecideByFit({Cand("a", 1, -1), Cand("b", 2, NAN)}, CategoryFitOptions{}), "");
  EXPECT_EQ(DecideByFit({}, CategoryFitOptions{}), "");
}

TEST(CategoryFit, CandidatesPerCategoryFromThePool) {
  Rng rng(3);
  const Code q = RandomCode(rng, 8, 8, 16);
  std::vector<LabelledCode> e;
  e.push_back(Labelled("a0", "a", "a/i0", "x", FlipBits(q, rng, 30), 1.0));
  e.push_back(Labelled("a1", "a", "a/i1", "x", FlipBits(q, rng, 5), 1.0));
  e.push_back(Labelled("b0", "b", "b/i0", "x", FlipBits(q, rng, 20), 1.0));
  e.push_back(Labelled("c0", "c", "c/i0", "x", FlipBits(q, rng, 60), 2.0));  // twice as tall
  const Database db(std::move(e));
  std::vector<Match> m;
  db.matcher().MatchAll(PreparedQuery(q), &m);
  // The height gate keeps c out; a database entry's own instance is left out.
  EXPECT_EQ(CategoryPool(db, 1.0, 0.1), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(CategoryPool(db, 1.0, 0.1, "a/i1"), (std::vector<int>{0, 2}));
  EXPECT_EQ(CategoryPool(db, 1.0, 0), (std::vector<int>{0, 1, 2, 3}));
  CategoryFitOptions o;
  o.per_category = 1;
  o.top_categories = 0;
  std::vector<FitCandidate> c = ChooseFitCandidates(db, {0, 1, 2, 3}, m, o);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0].id, "a1");  // a's nearest
  EXPECT_EQ(c[1].id, "b0");
  EXPECT_EQ(c[2].id, "c0");
  o.per_category = 2;
  o.top_categories = 2;
  c = ChooseFitCandidates(db, {0, 1, 2, 3}, m, o);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0].id, "a1");
  EXPECT_EQ(c[1].id, "a0");
  EXPECT_EQ(c[2].id, "b0");
}

TEST(CategoryFit, ErrorHandling) {
  CategoryFitOptions o;
  o.per_category = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.top_categories = -1;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.bits_weight = -0.5;
  EXPECT_THROW(o.Validate(), Error);
  o.bits_weight = NAN;
  EXPECT_THROW(o.Validate(), Error);
  EXPECT_THROW(DecideByFit({}, o), Error);
  const TwoCategories t;
  EXPECT_THROW(ChooseFitCandidates(t.db, {}, t.matches, CategoryFitOptions{}), Error);
  EXPECT_THROW(DecideCategoryByFit(t.db, {}, t.matches, t.recon, t.Hung(), CategoryFitOptions{}), Error);
  // A database mesh that cannot be read is recorded failed; the others decide.
  auto shirt_unreadable = [&t](int entry) -> TriMesh {
    if (entry == 0) throw Error("hang.ply of entry s: no such file");
    return t.pants_hang;
  };
  CategoryFit fit = DecideCategoryByFit(t.db, {0, 1}, t.matches, t.recon, shirt_unreadable, CategoryFitOptions{});
  EXPECT_EQ(fit.category, "pants");
  EXPECT_LT(fit.candidates[0].fit, 0);
  EXPECT_NE(fit.candidates[0].failure.find("no such file"), std::string::npos);
  // An empty mesh cannot be registered; with every candidate failed there is no answer.
  fit = DecideCategoryByFit(
      t.db, {0, 1}, t.matches, t.recon, [](int) { return TriMesh{}; }, CategoryFitOptions{});
  EXPECT_EQ(fit.category, "");
  for (const FitCandidate& c : fit.candidates) EXPECT_FALSE(c.failure.empty());
}

TEST(CategoryFit, TurnedToQueryTurnsAboutTheGripperAxis) {
  TriMesh m;
  m.V.resize(1, 3);
  m.V.row(0) = Vec3(1, -0.5, 0).transpose();
  const TriMesh t = TurnedToQuery(m, 4, 16);  // a quarter turn about +y
  EXPECT_NEAR(t.V(0, 0), 0, 1e-12);
  EXPECT_NEAR(t.V(0, 1), -0.5, 1e-12);
  EXPECT_NEAR(t.V(0, 2), -1, 1e-12);
  EXPECT_NEAR(TurnedToQuery(m, 16, 16).V(0, 0), 1, 1e-12);
}

}  // namespace
}  // namespace drape::recognition
