#include "runtime/recognition/evaluate.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "common/error.h"
#include "common/files.h"
#include "common/proportion.h"
#include "common/rng.h"
#include "runtime/recognition/test_features.h"

namespace drape::recognition {
namespace {

namespace fs = std::filesystem;

// pants: 2 instances × anchors {a, b}; shorts: 1 instance × {a, c}. Queries are small
// perturbations of one instance's entry, except one pants query built to be nearest to
// instance 1's "b" while labelled "a" (a known mistake) and one towel query whose category
// the database lacks.
TEST(RecognitionEvaluate, CountsTheTableAndWritesTheReport) {
  Rng rng(9);
  std::map<std::string, Code> proto;
  for (const char* k : {"pants/a", "pants/b", "shorts/a", "shorts/c"}) proto[k] = RandomCode(rng, 4, 4, 8);
  std::vector<LabelledCode> train = {
      Labelled("p1a", "pants", "pants-1", "a", FlipBits(proto["pants/a"], rng, 2)),
      Labelled("p1b", "pants", "pants-1", "b", FlipBits(proto["pants/b"], rng, 2)),
      Labelled("p2a", "pants", "pants-2", "a", FlipBits(proto["pants/a"], rng, 2)),
      Labelled("p2b", "pants", "pants-2", "b", FlipBits(proto["pants/b"], rng, 2)),
      Labelled("s1a", "shorts", "shorts-1", "a", FlipBits(proto["shorts/a"], rng, 2)),
      Labelled("s1c", "shorts", "shorts-1", "c", FlipBits(proto["shorts/c"], rng, 2)),
  };
  Database db(train);
  std::vector<EvalQuery> qs;
  auto add = [&](LabelledCode lc, double fus) {
    EvalQuery q;
    q.query = std::move(lc);
    q.fusion_seconds = fus;
    q.feature_seconds = 0.01;
    q.timing_source = "test";
    qs.push_back(std::move(q));
  };
  add(Labelled("q1", "pants", "pants-q", "a", Rotate(FlipBits(proto["pants/a"], rng, 1), 3)), 0.2);
  add(Labelled("q2", "pants", "pants-q", "b", FlipBits(proto["pants/b"], rng, 1)), 0.2);
  add(Labelled("q3", "pants", "pants-q", "a", train[1].code), 0.2);  // looks exactly like pants-1 "b"
  add(Labelled("q4", "shorts", "shorts-q", "c", FlipBits(proto["shorts/c"], rng, 1)), -1);
  add(Labelled("q5", "towel", "towel-q", "corner", RandomCode(rng, 4, 4, 8)), -1);
  AnchorUvMap uvs = {{{"pants-q", "a"}, Vec2(0, 0)}, {{"pants-q", "b"}, Vec2(0.3, 0.4)}};

  const EvalResult res = Evaluate(db, nullptr, qs, uvs, {});
  const Json& r = res.report;
  ASSERT_EQ(r["categories"].size(), 3u);
  const Json& pants = r["categories"][0];
  EXPECT_EQ(pants["category"], "pants");
  EXPECT_EQ(pants["queries"], 3);
  EXPECT_DOUBLE_EQ(pants["pose_accuracy"]["both"]["unweighted"].get<double>(), 2.0 / 3);
  EXPECT_TRUE(pants["pose_accuracy"]["both"]["learned"].is_null());  // no weights
  EXPECT_DOUBLE_EQ(pants["category_accuracy"].get<double>(), 1.0);
  // q3's error is the uv distance a–b on its own pattern: 50 cm; mean over 3 queries.
  EXPECT_NEAR(pants["grasp_error_cm"]["unweighted_mean"].get<double>(), 50.0 / 3, 1e-9);
  EXPECT_DOUBLE_EQ(pants["top_k_accuracy"]["unweighted"].get<double>(), 1.0);  // only 2 anchors
  const Json& shorts = r["categories"][1];
  EXPECT_TRUE(shorts["pose_accuracy"]["instance2"]["unweighted"].is_null());  // one instance: n/a
  EXPECT_DOUBLE_EQ(shorts["pose_accuracy"]["instance1"]["unweighted"].get<double>(), 1.0);
  const Json& towel = r["categories"][2];
  EXPECT_EQ(towel["queries_category_absent"], 1);
  EXPECT_DOUBLE_EQ(towel["pose_accuracy"]["both"]["unweighted"].get<double>(), 0.0);
  EXPECT_EQ(r["warnings"].size(), 1u);
  // Overall: 3 right of 5 (q1, q2, q4).
  EXPECT_DOUBLE_EQ(r["overall"]["pose_accuracy"]["both"]["unweighted"].get<double>(), 3.0 / 5);
  EXPECT_EQ(r["overall"]["seconds_per_query"]["fusion_known"], 3);
  // Confusion for pants: true a → predicted b once.
  const auto& conf = res.confusion.at("pants");
  ASSERT_EQ(conf.labels, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(conf.counts[0][0], 1);
  EXPECT_EQ(conf.counts[0][1], 1);
  EXPECT_EQ(conf.counts[1][1], 1);

  const fs::path dir = fs::temp_directory_path() / ("drape_eval_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  WriteReport(res, Json{{"release", "synthetic"}}, dir);
  for (const char* f : {"report.md", "report.json", "accuracy.png", "confusion_pants.png", "confusion_shorts.png"}) {
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  }
  EXPECT_EQ(ReadFile(dir / "accuracy.png").substr(1, 3), "PNG");
  const Json back = Json::parse(ReadFile(dir / "report.json"));
  EXPECT_EQ(back["release"], "synthetic");
  EXPECT_NE(ReadFile(dir / "report.md").find("| pants (pants-1, pants-2) | 3 |"), std::string::npos);
  // At most two instances per category: the paper's columns, the last still "both".
  EXPECT_NE(ReadFile(dir / "report.md").find("| category | queries | instance 1 | instance 2 | both | paper: "),
            std::string::npos);
  EXPECT_FALSE(r["overall"]["pose_accuracy"].contains("instance3"));
  EXPECT_FALSE(r["overall"]["pose_accuracy"].contains("instances1_2"));
  if (!std::getenv("DRAPE_KEEP_TEST_OUTPUT")) fs::remove_all(dir);

  EXPECT_THROW(Evaluate(Database(), nullptr, qs, uvs, {}), Error);
  EXPECT_THROW(Evaluate(db, nullptr, {}, uvs, {}), Error);
}

// A row's precision: its counts, their 95 % Wilson interval (common/proportion.h), the
// difference a second run of the same size must show, and the report's line.
TEST(RecognitionEvaluate, PrecisionIsTheCountsWithTheirInterval) {
  Rng rng(5);
  const Code a = RandomCode(rng, 4, 4, 8), b = RandomCode(rng, 4, 4, 8);
  const Database db({Labelled("a", "pants", "pants-1", "a", a), Labelled("b", "pants", "pants-1", "b", b)});
  // Three right; two labelled "a" that look like "b" (wrong, and "a" has no twin).
  const std::vector<std::pair<const char*, Code>> queries = {{"a", FlipBits(a, rng, 1)},
                                                             {"a", FlipBits(a, rng, 1)},
                                                             {"b", FlipBits(b, rng, 1)},
                                                             {"a", b},
                                                             {"a", FlipBits(b, rng, 1)}};
  std::vector<EvalQuery> qs;
  for (const auto& [label, code] : queries)
    qs.emplace_back().query = Labelled("q" + std::to_string(qs.size()), "pants", "pants-q", label, code);
  const EvalResult res = Evaluate(db, nullptr, qs, {}, {});
  const Json& prec = res.report["categories"][0]["precision"];
  EXPECT_EQ(prec["metric"], "unweighted");
  EXPECT_EQ(prec["strict"]["correct"], 3);
  EXPECT_EQ(prec["strict"]["n"], 5);
  EXPECT_DOUBLE_EQ(prec["strict"]["low"].get<double>(), WilsonInterval(3, 5).low);
  EXPECT_DOUBLE_EQ(prec["strict"]["high"].get<double>(), WilsonInterval(3, 5).high);
  EXPECT_EQ(prec["twin_credited"]["correct"], 3);
  EXPECT_EQ(prec["category"]["correct"], 5);
  EXPECT_EQ(prec["category"]["high"], 1.0);
  EXPECT_DOUBLE_EQ(prec["strict_difference_beyond_chance"].get<double>(), DifferenceBeyondChance(0.6, 5));
  EXPECT_EQ(prec["strict_queries_for_5_points"], TrialsForDifference(0.6, 0.05));
  const std::string md = ReportMarkdown(res.report);
  EXPECT_NE(
      md.find("| pants | 3 / 5: 60.0 % (23.1–88.2 %) | 3 / 5: 60.0 % (23.1–88.2 %) | 5 / 5: 100.0 % (56.6–100.0 %)"),
      std::string::npos)
      << md;

  // Weights for pants only, a shorts query without: the "all" row prints the learned
  // figure (over the pants queries), and its interval is of that figure.
  const Code c = RandomCode(rng, 4, 4, 8);
  const Database db2({Labelled("a", "pants", "pants-1", "a", a), Labelled("b", "pants", "pants-1", "b", b),
                      Labelled("c", "shorts", "shorts-1", "c", c)});
  qs.emplace_back().query = Labelled("qs", "shorts", "shorts-q", "c", FlipBits(c, rng, 1));
  Weights w;
  w.layers = 4, w.rings = 4, w.sectors = 8;
  w.per_category["pants"] = std::vector<double>(128, 1.0);  // one per bit: 4 × 4 × 8
  const Json all = Evaluate(db2, &w, qs, {}, {}).report["overall"];
  EXPECT_EQ(all["precision"]["metric"], "learned");
  EXPECT_EQ(all["precision"]["strict"]["n"], 5);
  EXPECT_DOUBLE_EQ(all["precision"]["strict"]["correct"].get<int>() / 5.0,
                   all["pose_accuracy"]["both"]["learned"].get<double>());
}

// Three shirt instances, each holding all six query codes with `flips[k][j]` bits inverted
// (nested: fewer flips = nearer) under label a (right) or b (wrong). Alone: instance 1 is
// right for q0–q2 (3/6), instance 2 for q3–q4 (2/6), instance 3 for q5 (1/6). Instances
// 1–2: the nearer of the two decides, right for q0–q3 (4/6); all three: also q5 (5/6).
// The one-instance shorts get n/a for instances 2 and 3.
TEST(RecognitionEvaluate, EveryInstanceGetsAColumnAndThePaperPairIsReported) {
  Rng rng(21);
  const int flips[3][6] = {{1, 1, 1, 2, 1, 2}, {2, 2, 2, 1, 2, 3}, {3, 3, 3, 3, 3, 1}};
  const char* right[3] = {"aaabbb", "bbbaab", "bbbbba"};
  auto flipped = [](Code c, int n) {
    for (int i = 0; i < n; ++i) c.Set(37 * i, !c.Get(37 * i));
    return c;
  };
  std::vector<Code> codes;
  std::vector<LabelledCode> train;
  std::vector<EvalQuery> qs(6);
  for (int j = 0; j < 6; ++j) {
    codes.push_back(RandomCode(rng, 4, 4, 8));
    qs[j].query = Labelled("q" + std::to_string(j), "shirt", "shirt-q", "a", codes[j]);
    for (int k = 0; k < 3; ++k) {
      const std::string inst = "shirt-" + std::to_string(k + 1);
      train.push_back(Labelled(inst + "/" + std::to_string(j), "shirt", inst, right[k][j] == 'a' ? "a" : "b",
                               flipped(codes[j], flips[k][j])));
    }
  }
  const Code shorts_code = RandomCode(rng, 4, 4, 8);
  train.push_back(Labelled("s", "shorts", "shorts-1", "c", shorts_code));
  qs.emplace_back().query = Labelled("qs", "shorts", "shorts-q", "c", shorts_code);
  const EvalResult res = Evaluate(Database(train), nullptr, qs, {}, {});
  const Json& shirt = res.report["categories"][0]["pose_accuracy"];
  EXPECT_DOUBLE_EQ(shirt["instance1"]["unweighted"].get<double>(), 3.0 / 6);
  EXPECT_DOUBLE_EQ(shirt["instance2"]["unweighted"].get<double>(), 2.0 / 6);
  EXPECT_DOUBLE_EQ(shirt["instance3"]["unweighted"].get<double>(), 1.0 / 6);
  EXPECT_DOUBLE_EQ(shirt["instances1_2"]["unweighted"].get<double>(), 4.0 / 6);
  EXPECT_DOUBLE_EQ(shirt["both"]["unweighted"].get<double>(), 5.0 / 6);  // all instances
  const Json& shorts = res.report["categories"][1]["pose_accuracy"];
  EXPECT_TRUE(shorts["instance2"]["unweighted"].is_null());
  EXPECT_TRUE(shorts["instance3"]["unweighted"].is_null());
  EXPECT_DOUBLE_EQ(shorts["instances1_2"]["unweighted"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(res.report["overall"]["pose_accuracy"]["instance3"]["unweighted"].get<double>(), 1.0 / 6);
  const std::string md = ReportMarkdown(res.report);
  EXPECT_NE(md.find("| category | queries | instance 1 | instance 2 | instance 3 | instances 1–2 | all | paper: "),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| shirt (shirt-1, shirt-2, shirt-3) | 6 | 50.0 % / n/a | 33.3 % / n/a | 16.7 % / n/a | "
                    "66.7 % / n/a | 83.3 % / n/a |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| shorts (shorts-1) | 1 | 100.0 % / n/a | n/a / n/a | n/a / n/a | 100.0 % / n/a |"),
            std::string::npos)
      << md;
}

TEST(RecognitionEvaluate, SymmetryTwinsSwapWholeSideTokens) {
  using V = std::vector<std::string>;
  EXPECT_EQ(SymmetryTwins("left_cuff"), V{"right_cuff"});
  EXPECT_EQ(SymmetryTwins("right_leg_inner"), V{"left_leg_inner"});
  EXPECT_EQ(SymmetryTwins("top_left"), (V{"top_right", "bottom_left", "bottom_right"}));
  EXPECT_EQ(SymmetryTwins("bottom_center"), V{"top_center"});
  EXPECT_EQ(SymmetryTwins("waist_center"), V{});
  EXPECT_EQ(SymmetryTwins("crotch"), V{});
  EXPECT_EQ(SymmetryTwins("leftover_right"), V{"leftover_left"});
}

// A query matched to its anchor's mirror twin is wrong strictly and right twin credited;
// one matched to an unrelated anchor is wrong both ways.
TEST(RecognitionEvaluate, TwinCreditedAccuracy) {
  Rng rng(11);
  std::vector<LabelledCode> train = {Labelled("l", "shorts", "s-1", "left_leg", RandomCode(rng, 4, 4, 8)),
                                     Labelled("r", "shorts", "s-1", "right_leg", RandomCode(rng, 4, 4, 8)),
                                     Labelled("w", "shorts", "s-1", "waist", RandomCode(rng, 4, 4, 8))};
  Database db(train);
  std::vector<EvalQuery> qs(2);
  qs[0].query = Labelled("q0", "shorts", "s-q", "left_leg", train[1].code);  // looks like right_leg
  qs[1].query = Labelled("q1", "shorts", "s-q", "waist", train[0].code);     // looks like left_leg
  const Json r = Evaluate(db, nullptr, qs, {}, {}).report;
  const Json& c = r["categories"][0];
  EXPECT_DOUBLE_EQ(c["pose_accuracy"]["both"]["unweighted"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(c["pose_accuracy_twin_credited"]["unweighted"].get<double>(), 0.5);
  EXPECT_TRUE(c["pose_accuracy_twin_credited"]["learned"].is_null());  // no weights
}

}  // namespace
}  // namespace drape::recognition
