// The miss curve of `drape eval` (issue 45): pose recognition on the test split's
// garments with the grasp exactly 0 / 5 mm / 1 cm / ... from the anchor (the recipe's
// `miss_curve`, built as splits test_miss_<mm>mm), beside the headline, the test split
// itself (the protocol's random miss). One table, strict and twin-credited pose accuracy
// per category at each level, and category accuracy.
#pragma once

#include <string>
#include <vector>

#include "common/json.h"
#include "generator/release/release.h"
#include "runtime/recognition/evaluate.h"

namespace drape {
struct Recipe;
}

namespace drape::recognition {

struct MissLevel {
  std::string split;    // test_miss_<mm>mm
  double miss_m = 0;    // the grasp's distance from the anchor
  std::string differs;  // the split's sensing and perturbation in words
};

// Whether the release has entries in a test_miss_<mm>mm split (then its recipe is read).
bool HasMissSplits(const Release& release);

// The levels of the release's recipe (ReleaseRecipe, parsed once by the caller) that
// have entries, ascending; empty when the recipe has no miss curve.
std::vector<MissLevel> MissCurveLevels(const Release& release, const Recipe& recipe);

// How the recipe's test split differs from a database entry (for the headline row); ""
// when the recipe has no test split.
std::string DescribeTestSplit(const Recipe& recipe);

struct MissPoint {
  MissLevel level;
  EvalResult eval;
};

// report.json "miss_curve": {"metric", "headline": row or null, "levels": [rows]}, a row
// {"split", "miss_mm" (null for the headline), "differs", "categories": {category or
// "all": {"queries", "strict": {unweighted, learned}, "twin_credited": {...},
// "category_accuracy"}}}. `headline` may be null (the evaluated split is not test).
Json MissCurveTable(const EvalResult* headline, const std::string& headline_differs,
                    const std::vector<MissPoint>& points);
std::string MissCurveMarkdown(const Json& table);

}  // namespace drape::recognition
