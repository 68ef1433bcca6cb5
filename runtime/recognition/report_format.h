// Cells of the eval's markdown tables: internal to drape_recognition (eval_report.cpp,
// ladder.cpp, miss_curve.cpp and k_curve.cpp write the same figures the same way).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "common/json.h"

namespace drape::recognition {

// A share in [0, 1] as "42.1 %"; "n/a" for null (no query of that kind).
inline std::string PercentCell(const Json& v) {
  if (v.is_null()) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", 100.0 * v.get<double>());
  return buf;
}

// One category's row of an eval report (report.json "categories"[i] or "overall") as the
// curves' tables hold it: {queries, strict, twin_credited, category_accuracy}.
inline Json CurveFigures(const Json& c) {
  const Json none{{"unweighted", nullptr}, {"learned", nullptr}};
  return {{"queries", c["queries"]},
          {"strict", c["pose_accuracy"]["both"]},
          {"twin_credited", c.value("pose_accuracy_twin_credited", none)},
          {"category_accuracy", c["category_accuracy"]}};
}

// Every category's CurveFigures of an eval report, and "all" for the overall row.
inline Json CurveFiguresByCategory(const Json& report) {
  Json cats = Json::object();
  for (const Json& c : report["categories"]) cats[c["category"].get<std::string>()] = CurveFigures(c);
  cats["all"] = CurveFigures(report["overall"]);
  return cats;
}

// "strict / twin credited" of CurveFigures in the runtime's distance: learned where the
// category has weights, else unweighted.
inline std::string StrictTwinCell(const Json& f) {
  const char* m = f["strict"]["learned"].is_null() ? "unweighted" : "learned";
  return PercentCell(f["strict"][m]) + " / " + PercentCell(f["twin_credited"][m]);
}

// The columns of a curve's table: its categories (CurveFiguresByCategory's keys) then "all".
inline std::vector<std::string> CurveColumns(const Json& categories) {
  std::vector<std::string> cols;
  for (const auto& [cat, f] : categories.items())
    if (cat != "all") cols.push_back(cat);
  cols.push_back("all");
  return cols;
}

// A curve table's header and rule: its leading columns, then `cols`, then "category".
inline std::string CurveHeader(const std::vector<std::string>& lead, const std::vector<std::string>& cols) {
  std::string head = "|", rule = "|";
  auto column = [&](const std::string& name) {
    head += ' ';
    head += name;
    head += " |";
    rule += "---|";
  };
  for (const auto& c : lead) column(c);
  for (const auto& c : cols) column(c);
  column("category");
  return head + "\n" + rule + "\n";
}

// A curve row's cells after its leading ones: StrictTwinCell per column ("—" where the
// row lacks the category), then category accuracy; "| a | b | c |\n" style.
inline std::string CurveCells(const Json& categories, const std::vector<std::string>& cols) {
  std::string out;
  // Appended piecewise: " " + a temporary string trips gcc 12's -Wrestrict (a false
  // positive in libstdc++'s insert, GCC bug 105329), an error under DRAPE_WERROR.
  for (const auto& c : cols) {
    out += ' ';
    out += categories.contains(c) ? StrictTwinCell(categories[c]) : std::string("—");
    out += " |";
  }
  return out + " " + PercentCell(categories["all"]["category_accuracy"]) + " |\n";
}

}  // namespace drape::recognition
