// The miss curve's table from eval results (report.json rows as Evaluate writes them).
#include "runtime/recognition/miss_curve.h"

#include <gtest/gtest.h>

namespace drape::recognition {
namespace {

// An eval result with one category and the overall row: `right` of `n` strict, `twins`
// more twin credited, unweighted only (no weights).
EvalResult Result(const std::string& category, int n, int right, int twins) {
  auto row = [&](const std::string& name) {
    return Json{{"category", name},
                {"queries", n},
                {"pose_accuracy", {{"both", {{"unweighted", double(right) / n}, {"learned", nullptr}}}}},
                {"pose_accuracy_twin_credited", {{"unweighted", double(right + twins) / n}, {"learned", nullptr}}},
                {"category_accuracy", 1.0}};
  };
  EvalResult r;
  r.report["categories"] = Json::array({row(category)});
  r.report["overall"] = row("all");
  return r;
}

TEST(MissCurve, RowsPerLevelBesideTheHeadline) {
  const EvalResult head = Result("pants", 4, 3, 1);
  const std::vector<MissPoint> points = {{{"test_miss_0mm", 0, "grasp 0 mm"}, Result("pants", 4, 4, 0)},
                                         {{"test_miss_30mm", 0.03, "grasp 30 mm"}, Result("pants", 4, 1, 2)}};
  const Json t = MissCurveTable(&head, "grasp miss σ 10 mm per axis", points);
  EXPECT_EQ(t["headline"]["split"], "test");
  EXPECT_TRUE(t["headline"]["miss_mm"].is_null());
  ASSERT_EQ(t["levels"].size(), 2u);
  EXPECT_EQ(t["levels"][1]["miss_mm"], 30);
  EXPECT_DOUBLE_EQ(t["levels"][1]["categories"]["pants"]["strict"]["unweighted"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(t["levels"][1]["categories"]["all"]["twin_credited"]["unweighted"].get<double>(), 0.75);
  const std::string md = MissCurveMarkdown(t);
  EXPECT_NE(md.find("| test (grasp miss σ 10 mm per axis) | 4 | 75.0 % / 100.0 % |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 30 mm | 4 | 25.0 % / 75.0 % | 25.0 % / 75.0 % | 100.0 % |"), std::string::npos) << md;
}

TEST(MissCurve, NoHeadlineWhenAnotherSplitIsEvaluated) {
  const Json t = MissCurveTable(nullptr, "", {{{"test_miss_5mm", 0.005, "grasp 5 mm"}, Result("towel", 2, 1, 0)}});
  EXPECT_TRUE(t["headline"].is_null());
  const std::string md = MissCurveMarkdown(t);
  EXPECT_EQ(md.find("| test ("), std::string::npos);
  EXPECT_NE(md.find("| 5 mm | 2 | 50.0 % / 50.0 % |"), std::string::npos) << md;
  EXPECT_EQ(MissCurveMarkdown(MissCurveTable(nullptr, "", {})), "");
}

}  // namespace
}  // namespace drape::recognition
