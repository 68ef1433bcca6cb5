// The category from every hang (category.h).
#include "runtime/unfolding/category.h"

#include <algorithm>
#include <limits>

#include "common/error.h"

namespace drape::unfolding {

namespace rec = drape::recognition;

Json HangEvidence::ToJson() const {
  Json per = Json::object();
  for (const PerCategory& c : categories)
    per[c.category] = {{"distance", c.distance < 0 ? Json(nullptr) : Json(c.distance)},
                       {"ungated", c.ungated},
                       {"gated_excess", c.gated_excess},
                       {"ungated_excess", c.ungated_excess},
                       {"excess", c.excess}};
  return {{"nearest", nearest}, {"bits", bits}, {"per_category", std::move(per)}};
}

HangEvidence EvidenceOfHang(const rec::Database& db, const std::vector<rec::Match>& matches, double query_height,
                            double tau, double gated_out_excess, double ungated_weight) {
  DRAPE_CHECK(ungated_weight >= 0, "the ungated excess's weight must be >= 0");
  DRAPE_CHECK(!db.empty() && static_cast<int>(matches.size()) == db.size(), "one match per database entry");
  HangEvidence e;
  e.bits = db.layers() * db.rings() * db.sectors();
  DRAPE_CHECK(e.bits > 0, "the database's features have no bits");
  std::vector<int> all(db.size());
  for (int i = 0; i < db.size(); ++i) all[i] = i;
  const std::vector<int> pool = rec::HeightGated(db, all, query_height, tau);
  e.nearest = db.label(rec::NearestUnweighted(pool, matches)).category;
  std::vector<char> in_pool(db.size(), 0);
  for (int i : pool) in_pool[i] = 1;
  int best = std::numeric_limits<int>::max(), best_ungated = std::numeric_limits<int>::max();
  for (const std::string& c : db.categories()) {
    HangEvidence::PerCategory pc;
    pc.category = c;
    for (int i : db.EntriesOf(c)) {
      const int d = matches[i].distance;
      if (pc.ungated < 0 || d < pc.ungated) pc.ungated = d;
      if (in_pool[i] && (pc.distance < 0 || d < pc.distance)) pc.distance = d;
    }
    if (pc.distance >= 0) best = std::min(best, pc.distance);
    best_ungated = std::min(best_ungated, pc.ungated);
    e.categories.push_back(pc);
  }
  double worst_in_pool = 0;
  for (HangEvidence::PerCategory& pc : e.categories) {
    if (pc.distance < 0) continue;
    pc.gated_excess = double(pc.distance - best) / e.bits;
    worst_in_pool = std::max(worst_in_pool, pc.gated_excess);
  }
  for (HangEvidence::PerCategory& pc : e.categories) {
    if (pc.distance < 0)
      pc.gated_excess = std::max({double(pc.ungated - best) / e.bits, worst_in_pool, gated_out_excess});
    pc.ungated_excess = double(pc.ungated - best_ungated) / e.bits;
    pc.excess = pc.gated_excess + ungated_weight * pc.ungated_excess;
  }
  return e;
}

bool CategoryDecision::Add(const HangEvidence& e, double weight) {
  DRAPE_CHECK(weight >= 0, "a hang's evidence weight must be >= 0");
  for (const HangEvidence::PerCategory& pc : e.categories) totals_[pc.category] += weight * pc.excess;
  ++hangs_;
  const std::string before = decided_;
  if (decided_.empty()) decided_ = e.nearest;
  // The least accumulated excess; ties keep the decision standing.
  for (const auto& [c, total] : totals_)
    if (total < totals_[decided_]) decided_ = c;
  return !before.empty() && decided_ != before;
}

std::string SummedFitCategory(const std::vector<std::map<std::string, double>>& hangs, const std::string& standing,
                              double absent_penalty) {
  DRAPE_CHECK(absent_penalty >= 0, "the absent category's penalty must be >= 0");
  std::map<std::string, double> total;
  for (const auto& h : hangs)
    for (const auto& [c, score] : h) total[c] = 0;
  for (const auto& h : hangs) {
    if (h.empty()) continue;
    double worst = 0;
    for (const auto& [c, score] : h) worst = std::max(worst, score);
    for (auto& [c, sum] : total) {
      const auto it = h.find(c);
      sum += it == h.end() ? worst + absent_penalty : it->second;
    }
  }
  std::string best;
  for (const auto& [c, sum] : total)
    if (best.empty() || sum < total[best] || (sum == total[best] && c == standing)) best = c;
  return best;
}

}  // namespace drape::unfolding
