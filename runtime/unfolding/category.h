// The garment's category from every hang of a trial (LoopOptions::category_evidence).
//
// Recognition decides the category by the unweighted nearest neighbour over the whole
// database (Eq. match, bits: the one scale common to all categories; recognizer.h). The
// first hang is from a random grasp point, a shape the database (hung from anchors only)
// never shows, and a category decided there alone is wrong in a few trials per ten
// (pants taken for a long-sleeve shirt), which no later step can undo. Here each hang
// adds evidence for every category and the decision is the category with the least
// accumulated evidence against it:
//
//   per hang t and category c: d_c = the best Eq. match distance among c's entries in the
//   height-gated pool (recognition's category gate τ by default); gated excess
//   g_c = (d_c − min_c' d_c') / bits ≥ 0 (0 for the hang's nearest category); a category
//   with no entry in the gated pool (its hangs are all of another height) gets the
//   largest of its ungated excess, the largest excess of a category in the pool and
//   kGatedOutExcess: never nearer than the farthest one that passed the gate, and the
//   height counts against it even when one category alone passed;
//   ungated excess u_c = (the best distance among all c's entries − the least of those)
//   / bits: the shape alone (Algorithm 1 scales the height away), as the paper decides;
//   e_c = g_c + λ u_c (λ = `ungated_weight`: the loop's hangs, from a random grasp or
//   fallen from two grippers, hang at heights the database never shows, so the gate
//   alone leaves the garment's own entries out too often);
//   E_c = Σ_t w_t e_c,t, and the decision is argmin_c E_c (ties keep the decision
//   standing; at the first hang, from the hang's gated nearest category).
//
// With λ = 0, one hang and recognition's category gate the decision is recognition's
// category, so a trial whose decision never changes is step for step the trial that
// decides the category once.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/json.h"
#include "runtime/recognition/matcher.h"
#include "runtime/recognition/recognizer.h"

namespace drape::unfolding {

// The least excess of a category gated out at a hang (a fraction of the code's bits).
inline constexpr double kGatedOutExcess = 0.01;

// One hang's evidence for each category of the database.
struct HangEvidence {
  struct PerCategory {
    std::string category;
    int distance = -1;  // bits: best Eq. match distance in the gated pool; -1: none there (gated out)
    int ungated = -1;   // bits: best over all the category's entries
    double gated_excess = 0, ungated_excess = 0;  // g_c, u_c (see above), fractions of the code's bits
    double excess = 0;                            // e_c = g_c + λ u_c
  };
  std::vector<PerCategory> categories;  // the database's, sorted by name
  std::string nearest;                  // the gated nearest neighbour's category (recognition's answer)
  int bits = 0;                         // the code's length
  Json ToJson() const;
};

// The evidence of one hang from its Eq. match against every database entry (`matches`,
// indexed by entry) under the category height gate `tau` for a query `query_height` m
// tall (0: unknown, no gate), as Recognizer::Rank decides the category, and λ =
// `ungated_weight` >= 0.
HangEvidence EvidenceOfHang(const recognition::Database& db, const std::vector<recognition::Match>& matches,
                            double query_height, double tau, double gated_out_excess = kGatedOutExcess,
                            double ungated_weight = 1.0);

// The accumulated decision over a trial's hangs.
class CategoryDecision {
 public:
  // Adds a hang's evidence with weight `weight` (>= 0). Returns true when the decision
  // changed (never at the first hang).
  bool Add(const HangEvidence& e, double weight = 1.0);
  const std::string& decided() const { return decided_; }
  const std::map<std::string, double>& totals() const { return totals_; }  // E_c
  int hangs() const { return hangs_; }

 private:
  std::string decided_;
  std::map<std::string, double> totals_;
  int hangs_ = 0;
};

// The category from the category-by-registration scores of a trial's hangs
// (LoopOptions::category_refit; recognition/category_fit.h: per hang, score_c of the
// nearest categories that took part, a category's best fit over the hang's best, so 1 for
// the hang's best and every hang weighs alike). A category that took no part at a hang
// (the height gate or the two nearest categories by Eq. match left it out) counts that
// hang's largest score plus `absent_penalty` (>= 0): never better than one that was
// registered, and with a penalty worse, so that a category left out at the first hang
// does not win by one later hang that it fits a little better. The least sum decides;
// ties keep `standing`. "" when no hang has a score.
std::string SummedFitCategory(const std::vector<std::map<std::string, double>>& hangs, const std::string& standing,
                              double absent_penalty = 0);

}  // namespace drape::unfolding
