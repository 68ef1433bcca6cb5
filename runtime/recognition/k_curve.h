// The K curve of `drape eval` (issue 45): for a release built with `hangs_per_anchor: K > 1`,
// pose recognition on the evaluated split with a database of each anchor's first K' hangs
// (hang index < K'; K' = 1, 2, 4, … and K), the same queries and weights each time: what
// more hangs per anchor buy. One table, strict and twin-credited pose accuracy per category
// at each K', and category accuracy; absent for K = 1 releases.
#pragma once

#include <string>
#include <vector>

#include "common/json.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

// 1 + the largest hang index in the database (1 for a database without hang records).
int HangsPerAnchor(const Database& db);

// K' = 1, 2, 4, … below K, then K itself (K = 6: 1, 2, 4, 6); {1} for K = 1.
std::vector<int> KCurveLevels(int k);

// The database of each anchor's first `k` hangs (entries whose hang index < k), in the
// database's order and with its kernel.
Database FirstHangs(const Database& db, int k);

struct KPoint {
  int hangs = 1;             // K'
  int database_entries = 0;  // entries of FirstHangs(db, K')
  EvalResult eval;
};

// Every level of KCurveLevels(HangsPerAnchor(db)) evaluated like `full` (the evaluation
// with the whole database, reused for K' = K); empty when the database has one hang per anchor.
std::vector<KPoint> KCurvePoints(const Database& db, const Weights* weights, const std::vector<EvalQuery>& queries,
                                 const AnchorUvMap& uvs, const EvalOptions& options, const EvalResult& full);

// report.json "k_curve": {"hangs_per_anchor": K, "levels": [{"hangs", "database_entries",
// "categories": {category or "all": {"queries", "strict": {unweighted, learned},
// "twin_credited": {...}, "category_accuracy"}}}]}.
Json KCurveTable(const std::vector<KPoint>& points);
std::string KCurveMarkdown(const Json& table);

}  // namespace drape::recognition
