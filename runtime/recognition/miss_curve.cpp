#include "runtime/recognition/miss_curve.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "runtime/recognition/release_recipe.h"
#include "runtime/recognition/report_format.h"

namespace drape::recognition {

bool HasMissSplits(const Release& release) {
  for (const auto& e : release.entries())
    if (e.split.rfind("test_miss_", 0) == 0) return true;
  return false;
}

namespace {

Json Row(const EvalResult& eval, const std::string& split, const Json& miss_mm, const std::string& differs) {
  return {{"split", split},
          {"miss_mm", miss_mm},
          {"differs", differs},
          {"categories", CurveFiguresByCategory(eval.report)}};
}

}  // namespace

std::vector<MissLevel> MissCurveLevels(const Release& release, const Recipe& recipe) {
  if (!HasMissSplits(release)) return {};
  std::set<std::string> present;
  for (const auto& e : release.entries()) present.insert(e.split);
  std::vector<MissLevel> out;
  for (const SplitSpec& s : recipe.splits)
    if (s.miss_level >= 0 && present.count(s.name)) out.push_back({s.name, s.miss_level, DescribeSplit(s)});
  std::sort(out.begin(), out.end(), [](const MissLevel& a, const MissLevel& b) { return a.miss_m < b.miss_m; });
  return out;
}

std::string DescribeTestSplit(const Recipe& recipe) {
  for (const SplitSpec& s : recipe.splits)
    if (s.name == "test") return DescribeSplit(s);
  return "";
}

Json MissCurveTable(const EvalResult* headline, const std::string& headline_differs,
                    const std::vector<MissPoint>& points) {
  Json levels = Json::array();
  for (const MissPoint& p : points)
    levels.push_back(Row(p.eval, p.level.split, std::lround(p.level.miss_m * 1000), p.level.differs));
  return {{"headline", headline ? Row(*headline, "test", nullptr, headline_differs) : Json(nullptr)},
          {"levels", levels}};
}

std::string MissCurveMarkdown(const Json& table) {
  std::vector<Json> rows;
  if (!table["headline"].is_null()) rows.push_back(table["headline"]);
  for (const Json& r : table["levels"]) rows.push_back(r);
  if (rows.empty()) return "";
  const std::vector<std::string> cats = CurveColumns(rows.front()["categories"]);
  std::ostringstream md;
  md << "## Miss curve (pose accuracy strict / twin credited, both database instances, category known)\n\n"
     << "The test split's garments with the grasp exactly this far from the anchor (one direction per anchor, "
        "the same at every level); the headline row is the test split itself, the protocol. Learned distance "
        "where the category has weights, else unweighted; category accuracy by the unweighted nearest "
        "neighbour.\n\n"
     << CurveHeader({"grasp miss", "queries"}, cats);
  for (const Json& r : rows) {
    const Json& all = r["categories"]["all"];
    md << "| "
       << (r["miss_mm"].is_null() ? "test (" + r["differs"].get<std::string>() + ")"
                                  : std::to_string(r["miss_mm"].get<int>()) + " mm")
       << " | " << all["queries"].get<int>() << " |";
    md << CurveCells(r["categories"], cats);
  }
  return md.str();
}

}  // namespace drape::recognition
