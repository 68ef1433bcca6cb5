#include "runtime/unfolding/objective.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/field_error.h"

namespace drape::unfolding {

std::vector<DesiredPair> DesiredPairsFor(const std::string& category) {
  if (category == "long_sleeve_shirt") return {{"left_elbow", "right_elbow"}};
  if (category == "pants" || category == "shorts") return {{"left_leg_outer", "right_leg_outer"}};
  if (category == "towel") {
    return {{"top_left", "top_right"},
            {"bottom_left", "bottom_right"},
            {"top_left", "bottom_left"},
            {"top_right", "bottom_right"}};
  }
  return {};
}

void ObjectiveOptions::Validate() const {
  if (!(sigma_length > 0 && sigma_length < 10))
    BadField(sigma_length, "ObjectiveOptions.sigma_length", "must be in (0, 10) m");
  if (!(xi > 0 && xi <= 1)) BadField(xi, "ObjectiveOptions.xi", "must be in (0, 1]");
  if (!(min_separation >= 0 && min_separation < 10))
    BadField(min_separation, "ObjectiveOptions.min_separation", "must be in [0, 10) m");
}

ScoreTable::ScoreTable(std::vector<AnchorPoint> anchors, std::vector<DesiredPair> desired,
                       const ObjectiveOptions& options)
    : anchors_(std::move(anchors)), desired_(std::move(desired)), options_(options) {
  options_.Validate();
  if (desired_.empty()) throw Error("objective: no desired pair of grasp points");
  for (const DesiredPair& d : desired_) {
    const int a = IndexOf(d.first), b = IndexOf(d.second);
    if (a < 0 || b < 0) {
      throw Error("objective: the garment has no anchor '" + (a < 0 ? d.first : d.second) + "' of its desired pair (" +
                  d.first + ", " + d.second + ")");
    }
    desired_uv_.emplace_back(anchors_[a].uv, anchors_[b].uv);
  }
  const size_t n = anchors_.size();
  table_.resize(n * n);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) table_[i * n + j] = Score(anchors_[i].uv, anchors_[j].uv);
}

int ScoreTable::IndexOf(const std::string& label) const {
  for (size_t i = 0; i < anchors_.size(); ++i)
    if (anchors_[i].label == label) return static_cast<int>(i);
  return -1;
}

double ScoreTable::Score(const Vec2& a, const Vec2& b) const {
  const double sigma = 1.0 / (2 * options_.sigma_length * options_.sigma_length);
  double best = 0;
  for (const auto& [l, r] : desired_uv_) {
    // Either gripper may take either desired point.
    const double straight = (a - l).squaredNorm() + (b - r).squaredNorm();
    const double swapped = (a - r).squaredNorm() + (b - l).squaredNorm();
    best = std::max(best, std::exp(-sigma * std::min(straight, swapped)));
  }
  return best;
}

double ScoreTable::PointScore(const Vec2& x) const {
  const double sigma = 1.0 / (2 * options_.sigma_length * options_.sigma_length);
  double best = 0;
  for (const auto& [l, r] : desired_uv_)
    best = std::max(best, std::exp(-sigma * std::min((x - l).squaredNorm(), (x - r).squaredNorm())));
  return best;
}

ScoreTable::Next ScoreTable::BestNext(int current) const {
  DRAPE_CHECK(current >= 0 && current < size(), "current anchor out of range");
  Next best;
  for (int j = 0; j < size(); ++j) {
    if ((anchors_[j].uv - anchors_[current].uv).norm() < options_.min_separation) continue;
    const double f = (*this)(current, j);
    if (f > best.f) best = {j, f};  // ties: the first anchor in the garment's order
  }
  return best;
}

}  // namespace drape::unfolding
