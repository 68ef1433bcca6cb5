// The category over a trial's hangs (category.h).
#include "runtime/unfolding/category.h"

#include <algorithm>

#include "common/error.h"

namespace drape::unfolding {

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
