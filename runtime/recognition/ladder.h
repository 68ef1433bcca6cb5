// The ablation ladder of `drape eval --ladder` (issue 13): pose recognition on test-split
// variants that add one difference at a time between a database entry and a query —
// the database entries themselves turned and re-swept without noise, + Kinect noise,
// + grasp offset, + gripper encoder noise (the recipe's test_<rung> splits over train
// instances), then other instances (test, and test_<rung> splits over other
// instances, e.g. with material jitter). One table per category, and figures of the
// worst confusions (query reconstruction | matched entry | true database entry).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "common/json.h"
#include "generator/release/release.h"
#include "runtime/recognition/evaluate.h"

namespace drape {
struct Recipe;
}

namespace drape::recognition {

struct LadderRung {
  std::string split;
  std::string differs;              // what this rung changes w.r.t. the database entry
  bool database_instances = false;  // the queries are the database's own instances
};

// The rungs of the release's recipe that have entries, in ladder order: test_<rung>
// splits selecting only train instances (recipe order), test, then the other
// test_<rung> splits. Empty when the recipe has no test_<rung> split. `recipe`: the
// release's (ReleaseRecipe, parsed once by the caller).
std::vector<LadderRung> LadderRungs(const Release& release, const Recipe& recipe);

struct LadderResult {
  LadderRung rung;
  EvalResult eval;
};

// report.json "ladder": per category, one row per rung (queries, pose accuracy both
// instances unweighted / learned, category accuracy, mean grasp error).
Json LadderTable(const std::vector<LadderResult>& results);
std::string LadderMarkdown(const Json& table);

// For each rung and category, up to `per_category` wrong queries (both instances, the
// confusion matrix's metric), the most confident first (smallest matched distance):
// DIR/ladder_<split>_<category>_<k>.png = query recon.ply | matched entry | true entry
// (database entry with the query's anchor, the matched instance if it has it), all
// drawn at one scale from +z. Returns the file names with captions.
Json WriteWorstConfusions(const Release& release, const Database& db, const std::vector<LadderResult>& results,
                          const std::filesystem::path& dir, int per_category = 2);

}  // namespace drape::recognition
