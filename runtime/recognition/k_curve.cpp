#include "runtime/recognition/k_curve.h"

#include <algorithm>
#include <sstream>

#include "runtime/recognition/report_format.h"

namespace drape::recognition {

int HangsPerAnchor(const Database& db) {
  int k = 1;
  for (int i = 0; i < db.size(); ++i) k = std::max(k, db.label(i).hang + 1);
  return k;
}

std::vector<int> KCurveLevels(int k) {
  std::vector<int> out;
  for (int level = 1; level < k; level *= 2) out.push_back(level);
  out.push_back(k);
  return out;
}

Database FirstHangs(const Database& db, int k) {
  std::vector<LabelledCode> kept;
  for (int i = 0; i < db.size(); ++i)
    if (db.label(i).hang < k) kept.push_back({db.label(i), db.code(i)});
  return Database(std::move(kept), db.matcher().kernel());
}

std::vector<KPoint> KCurvePoints(const Database& db, const Weights* weights, const std::vector<EvalQuery>& queries,
                                 const AnchorUvMap& uvs, const EvalOptions& options, const EvalResult& full) {
  const int k = HangsPerAnchor(db);
  if (k == 1) return {};
  std::vector<KPoint> out;
  for (int level : KCurveLevels(k)) {
    if (level == k) {
      out.push_back({level, db.size(), full});
      continue;
    }
    const Database sub = FirstHangs(db, level);
    out.push_back({level, sub.size(), Evaluate(sub, weights, queries, uvs, options)});
  }
  return out;
}

Json KCurveTable(const std::vector<KPoint>& points) {
  Json levels = Json::array();
  for (const KPoint& p : points)
    levels.push_back({{"hangs", p.hangs},
                      {"database_entries", p.database_entries},
                      {"categories", CurveFiguresByCategory(p.eval.report)}});
  return {{"hangs_per_anchor", points.empty() ? 1 : points.back().hangs}, {"levels", levels}};
}

std::string KCurveMarkdown(const Json& table) {
  const Json& rows = table["levels"];
  if (rows.empty()) return "";
  const std::vector<std::string> cats = CurveColumns(rows.front()["categories"]);
  std::ostringstream md;
  md << "## K curve (pose accuracy strict / twin credited, both database instances, category known)\n\n"
     << "The same queries against a database of each anchor's first K' hangs (the release has "
     << table["hangs_per_anchor"].get<int>()
     << " per anchor: hang 0 as grasped exactly, the others varied by the recipe's `hang_variation`). "
        "Learned distance where the category has weights, else unweighted; category accuracy by the "
        "unweighted nearest neighbour.\n\n"
     << CurveHeader({"hangs per anchor", "database entries", "queries"}, cats);
  for (const Json& r : rows) {
    const Json& all = r["categories"]["all"];
    md << "| " << r["hangs"].get<int>() << " | " << r["database_entries"].get<int>() << " | "
       << all["queries"].get<int>() << " |";
    md << CurveCells(r["categories"], cats);
  }
  return md.str();
}

}  // namespace drape::recognition
