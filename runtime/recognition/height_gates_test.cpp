// Height gates (recognizer.h): the gate rule, its use in both steps of Rank, the
// search that calibration runs, and the weights file round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "common/error.h"
#include "common/files.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/recognition/test_features.h"

namespace drape::recognition {
namespace {

namespace fs = std::filesystem;

TEST(RecognitionHeightGates, GateIsABoundOnTheLogRatioAndUnknownHeightsPass) {
  EXPECT_TRUE(PassesHeightGate(1.0, 1.2, std::log(1.2) + 1e-12));
  EXPECT_FALSE(PassesHeightGate(1.0, 1.2, std::log(1.2) - 1e-9));
  EXPECT_FALSE(PassesHeightGate(1.2, 1.0, std::log(1.2) - 1e-9));  // symmetric
  EXPECT_TRUE(PassesHeightGate(1.0, 3.0, 0));                      // 0 = no gate
  EXPECT_TRUE(PassesHeightGate(0, 3.0, 0.1));                      // query height unknown
  EXPECT_TRUE(PassesHeightGate(1.0, 0, 0.1));                      // entry height unknown
}

// Shorts and pants with the same shape bits (Algorithm 1 scales the height away) but
// heights 0.5 and 1.2 m; the pants entry comes first, so without gates it wins ties.
struct ScaledTwins {
  Rng rng{5};
  Code waist = RandomCode(rng, 4, 4, 8), leg = RandomCode(rng, 4, 4, 8);
  Database db;
  ScaledTwins() {
    std::vector<LabelledCode> v;
    v.push_back(Labelled("p0", "pants", "pants-1", "waist", waist, 1.20));
    v.push_back(Labelled("p1", "pants", "pants-1", "leg", leg, 1.45));
    v.push_back(Labelled("s0", "shorts", "shorts-1", "waist", waist, 0.50));
    v.push_back(Labelled("s1", "shorts", "shorts-1", "leg", leg, 0.60));
    db = Database(std::move(v));
  }
};

TEST(RecognitionHeightGates, CategoryGateSeparatesGarmentsThatDifferOnlyInScale) {
  ScaledTwins t;
  Weights w;
  w.layers = 4, w.rings = 4, w.sectors = 8;
  w.height_gates = {0.3, 0};
  Recognizer rec(t.db, &w);
  RecognizeOptions o;
  o.weighted = false;
  // Unknown query height: no gate, the tie goes to the first entry (pants).
  EXPECT_EQ(rec.Recognize(t.waist, o).category, "pants");
  o.query_height = 0.52;
  const Recognition r = rec.Recognize(t.waist, o);
  EXPECT_EQ(r.category, "shorts");
  EXPECT_EQ(r.anchor, "waist");
  EXPECT_EQ(r.category_pool, 2);  // only the two shorts entries are within e^0.3 of 0.52 m
  EXPECT_EQ(r.gates, (HeightGates{0.3, 0}));
  // The paper's setting on the same query: gates off.
  o.height_gates = false;
  EXPECT_EQ(rec.Recognize(t.waist, o).category, "pants");
  // A gate no entry passes is widened to the nearest height's ratio + τ: a 5 m query
  // compares with the pants (1.2, 1.45 m), not with the shorts.
  o.height_gates = true;
  o.query_height = 5.0;
  const Recognition far = rec.Recognize(t.waist, o);
  EXPECT_EQ(far.category, "pants");
  EXPECT_EQ(far.category_pool, 2);
  o.query_height = 0.1;  // and a 10 cm one with the shorts, although pants come first
  EXPECT_EQ(rec.Recognize(t.waist, o).category, "shorts");
}

TEST(RecognitionHeightGates, PoseGateKeepsTheEntriesOfSimilarHeight) {
  // One category, two anchors with identical bits but different hung heights.
  Rng rng(9);
  const Code c = RandomCode(rng, 4, 4, 8);
  std::vector<LabelledCode> v;
  v.push_back(Labelled("a", "shirt", "shirt-1", "collar", c, 0.8));
  v.push_back(Labelled("b", "shirt", "shirt-1", "cuff", c, 1.45));
  Database db(std::move(v));
  Recognizer rec(db, nullptr);
  RecognizeOptions o;
  o.query_height = 1.4;
  o.gates = HeightGates{0, 0.1};
  const Recognition r = rec.Recognize(c, o);
  EXPECT_EQ(r.anchor, "cuff");
  EXPECT_EQ(r.pose_pool, 1);
  o.gates = HeightGates{0, 0};
  EXPECT_EQ(rec.Recognize(c, o).anchor, "collar");
  RecognizeOptions bad;
  bad.query_height = -1;
  EXPECT_THROW(rec.Recognize(c, bad), Error);
}

TEST(RecognitionHeightGates, SelectionFindsTheGateThatHeightInformsAndNoneOtherwise) {
  ScaledTwins t;
  // Queries of another garment instance: shorts at their own heights.
  std::vector<LabelledCode> qs;
  qs.push_back(Labelled("q0", "shorts", "shorts-2", "waist", t.waist, 0.51));
  qs.push_back(Labelled("q1", "shorts", "shorts-2", "leg", t.leg, 0.62));
  qs.push_back(Labelled("q2", "pants", "pants-2", "leg", t.leg, 1.40));
  qs.push_back(Labelled("q3", "pants", "pants-2", "waist", t.waist, 0));  // height unknown: left out
  CalibrateOptions opt;
  opt.gate_train_queries = false;
  const GateSelection g = SelectHeightGates(t.db, qs, opt);
  EXPECT_EQ(g.queries, 3);
  EXPECT_EQ(g.without_height, 1);
  ASSERT_EQ(g.taus.front(), 0);
  EXPECT_EQ(g.category_right.front(), 1);  // no gate: only the pants query is right
  EXPECT_EQ(g.chosen.category, 0.5);       // the weakest gate that gets all three
  for (size_t k = 1; k < g.taus.size(); ++k) EXPECT_EQ(g.category_right[k], 3) << g.taus[k];
  EXPECT_EQ(g.chosen.pose, 0);  // within a category the bits already tell the anchors apart

  // Heights that carry no information: every gate ties, the selection keeps none.
  std::vector<LabelledCode> same;
  for (const auto& q : qs) same.push_back(q), same.back().label.height = 1.0;
  ScaledTwins flat;
  std::vector<LabelledCode> v;
  for (int i = 0; i < flat.db.size(); ++i) {
    v.push_back({flat.db.label(i), flat.db.code(i)});
    v.back().label.height = 1.0;
  }
  const Database db1(std::move(v));
  const GateSelection g1 = SelectHeightGates(db1, same, opt);
  EXPECT_EQ(g1.chosen, (HeightGates{0, 0}));
}

TEST(RecognitionHeightGates, CategoryGateIsTheMostRightPoseGateTheWeakestWithinOneSe) {
  // drape calibrate's counts on paper.yaml with seed 2017 (hinge cloth, 85 selection
  // queries): the one-SE rule's slack (4.1 queries) took the category gate to 0.5, three
  // categories fewer than 0.15 gets.
  const std::vector<double> taus = {0, 0.5, 0.4, 0.3, 0.25, 0.2, 0.15, 0.12, 0.1, 0.08, 0.06, 0.05, 0.04, 0.03, 0.02};
  const std::vector<int> category = {57, 59, 59, 58, 59, 60, 62, 60, 60, 61, 51, 46, 46, 42, 39};
  const std::vector<int> pose = {28, 28, 28, 32, 33, 34, 34, 36, 37, 36, 32, 31, 31, 27, 30};
  EXPECT_EQ(ChooseHeightGates(taus, category, pose, 85), (HeightGates{0.15, 0.25}));
  // Seed 2016's: 70 at 0.03 (the one-SE rule: 0.06, 67).
  const std::vector<int> category16 = {51, 58, 56, 58, 58, 59, 60, 61, 62, 65, 67, 66, 67, 70, 68};
  const std::vector<int> pose16 = {21, 21, 22, 22, 24, 28, 30, 32, 34, 34, 35, 36, 36, 39, 37};
  EXPECT_EQ(ChooseHeightGates(taus, category16, pose16, 85), (HeightGates{0.03, 0.06}));
  // Ties keep the weakest; no queries, no gates.
  EXPECT_EQ(ChooseHeightGates({0, 0.5, 0.1}, {3, 5, 5}, {2, 2, 2}, 5), (HeightGates{0.5, 0}));
  EXPECT_EQ(ChooseHeightGates(taus, category, pose, 0), (HeightGates{0, 0}));
}

TEST(RecognitionHeightGates, TrainEntriesQueryTheOtherInstancesOnly) {
  ScaledTwins t;
  CalibrateOptions opt;  // gate_train_queries on: the four train entries are the queries
  const GateSelection g = SelectHeightGates(t.db, {}, opt);
  EXPECT_EQ(g.queries, 4);
  // Each pants entry's only other instance is the shorts one and vice versa: the right
  // category is never reachable, whatever the gate; the pose pool (same category, other
  // instances) is empty, so no pose answer counts either.
  for (size_t k = 0; k < g.taus.size(); ++k) {
    EXPECT_EQ(g.category_right[k], 0);
    EXPECT_EQ(g.pose_right[k], 0);
  }
}

TEST(RecognitionHeightGates, WeightsFileKeepsTheGatesAndOldFilesHaveNone) {
  const fs::path dir = fs::temp_directory_path() / "drape_height_gates_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Weights w;
  w.release_digest = "d";
  w.layers = 2, w.rings = 2, w.sectors = 2;
  w.per_category["pants"] = std::vector<double>(8, 1.0);
  w.height_gates = {0.25, 0.1};
  SaveWeights(w, dir);
  EXPECT_EQ(LoadWeights(dir, "d").height_gates, (HeightGates{0.25, 0.1}));
  // A weights.json from before the gates: none.
  Json j = Json::parse(ReadFile(dir / "weights.json"));
  j.erase("height_gates");
  WriteFileAtomic(dir / "weights.json", j.dump(2));
  EXPECT_EQ(LoadWeights(dir, "d").height_gates, (HeightGates{0, 0}));
  j["height_gates"] = {{"category", -1}, {"pose", 0}};
  WriteFileAtomic(dir / "weights.json", j.dump(2));
  EXPECT_THROW(LoadWeights(dir, "d"), Error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace drape::recognition
