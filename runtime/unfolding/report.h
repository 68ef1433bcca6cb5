// The paper's unfolding table (Fig. "garment_stat_unfold"): per category the trials,
// successful recognition, successful regrasping, successful unfolding and the average
// number of regrasps on success, next to the paper's; plus the variants (ablations).
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include "common/json.h"
#include "runtime/unfolding/loop.h"

namespace drape::unfolding {

// Distances (m, on the flat pattern) at which the report also counts the unfolded trials.
inline constexpr std::array<double, 4> kUnfoldedWithin = {0.04, 0.06, 0.08, 0.10};

// One row: counts over trials of one category under one variant.
struct TableRow {
  std::string category, variant;
  int trials = 0, recognised = 0, regrasped = 0, unfolded = 0;
  double regrasps_on_success = 0;  // mean over unfolded trials (0 if none)
  // Trials that reached f ≥ ξ with both grippers within kUnfoldedWithin[i] of a desired
  // pair: the success criterion's sensitivity to its distance (the paper's was judged by eye).
  std::array<int, 4> unfolded_within{};
  // Trials the loop declared unfolded (f ≥ ξ on its belief) whose grippers, by truth, are
  // not within the success distance of a desired pair: a success the robot would report
  // falsely (issue 45: there must be none).
  int declared_not_unfolded = 0;
  // The same trials as a loop declaring on the belief alone would have ended them, at the
  // first f ≥ ξ (TrialResult::belief_step): unfolded, declared but not, and the mean
  // regrasps of its successes; and the stops the verification held back.
  int belief_unfolded = 0, belief_not_unfolded = 0;
  double belief_regrasps_on_success = 0;
  int rejected = 0;
  int placed = 0;       // trials laid on the table
  double coverage = 0;  // mean coverage over placed trials (0 if none)
  double seconds = 0;   // mean wall seconds per trial
  StageTimes times;     // summed
};

TableRow Summarise(const std::string& category, const std::string& variant, const std::vector<TrialResult>& trials);

// report.json: {"rows": [...], "paper": {...}}.
Json ReportJson(const std::vector<TableRow>& rows);
// Markdown: the table per variant next to the paper's average row.
std::string ReportMarkdown(const std::vector<TableRow>& rows);

}  // namespace drape::unfolding
