#include "runtime/recognition/selection.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"

namespace drape::recognition {

int OneStandardError(const std::vector<int>& right, const std::vector<bool>& eligible, int n) {
  int best = -1;
  for (size_t k = 0; k < right.size(); ++k) {
    if (eligible[k]) best = std::max(best, right[k]);
  }
  if (best < 0 || n <= 0) return -1;
  const double p = double(best) / n;
  const double slack = std::sqrt(p * (1 - p) / n) * n;
  for (size_t k = 0; k < right.size(); ++k) {
    if (eligible[k] && right[k] >= best - slack) return static_cast<int>(k);
  }
  return -1;
}

int MostRight(const std::vector<int>& right) {
  if (right.empty()) return -1;
  return static_cast<int>(std::max_element(right.begin(), right.end()) - right.begin());
}

int NestedLeaveOneOut(const std::vector<std::vector<char>>& ok, const SelectionRule& rule, std::vector<int>* chosen) {
  if (chosen) chosen->clear();
  if (ok.empty()) return 0;
  const size_t settings = ok[0].size();
  std::vector<int> total(settings, 0);
  for (const auto& row : ok) {
    if (row.size() != settings) throw Error("nested leave-one-out: rows of different lengths");
    for (size_t g = 0; g < settings; ++g) total[g] += row[g] != 0;
  }
  const int others = static_cast<int>(ok.size()) - 1;
  int right = 0;
  std::vector<int> without(settings);
  for (const auto& row : ok) {
    for (size_t g = 0; g < settings; ++g) without[g] = total[g] - (row[g] != 0);
    const int k = rule(without, others);
    if (k >= 0 && static_cast<size_t>(k) < settings) right += row[k] != 0;
    if (chosen) chosen->push_back(k);
  }
  return right;
}

}  // namespace drape::recognition
