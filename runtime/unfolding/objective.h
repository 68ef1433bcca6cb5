// The paper's objective for regrasping (§"Problem Formulation", Eq. finalobj): a score
// over pairs of grasp points (x_l, x_r) on the garment's flat pattern, Gaussian around
// the desired pair (x_L*, x_R*),
//
//   ln f(x_l, x_r) = −σ_L ‖x_l − x_L*‖² − σ_R ‖x_r − x_R*‖² + ln p(x_l, x_r | y),
//
// discretised over the garment's anchor points S_g (a 2-D score table, one row and
// column per anchor). Which gripper is "left" is free, so a pair scores the better of
// its two assignments; a garment may have several equivalent desired pairs (a towel's
// four sides), and a pair scores the best of them. p(x_l, x_r | y) is the recognition's
// probability of the pair: recognition is a discrete classification here (the paper:
// "garment pose recognition can be treated as a discrete classification problem"), so
// p = 1 for the recognised current grasp and the planned next one; the table is then
// the Gaussian part, and f ∈ (0, 1] with f = 1 exactly at a desired pair.
//
// Units: uv positions in metres on the flat pattern; σ in 1/m², given as a length
// scale s (σ = 1/(2 s²)): at s from the desired point a gripper's factor is e^{-1/2}.
#pragma once

#include <string>
#include <vector>

#include "common/mesh.h"

namespace drape::unfolding {

// A desired pair of anchor labels; either gripper may take either.
struct DesiredPair {
  std::string first, second;
};

// The desired pairs of a category: long_sleeve_shirt {left_elbow, right_elbow} (the
// paper's); pants and shorts {left_leg_outer, right_leg_outer} (the two leg ends: the
// outer corners of the leg openings); towel the four pairs of adjacent corners. Empty
// for a category without one (tshirt, skirt, custom imports).
std::vector<DesiredPair> DesiredPairsFor(const std::string& category);

struct ObjectiveOptions {
  double sigma_length = 0.10;  // s, metres on the flat pattern (σ_L = σ_R = 1/(2 s²) = 50 m⁻²)
  // ξ: stop regrasping when f ≥ xi. 0.5 accepts e.g. one gripper exactly on a desired
  // anchor and the other within s·√(2 ln 2) ≈ 11.8 cm of the other.
  double xi = 0.5;
  // Candidates closer than this to the current grasp (metres, flat pattern) are not
  // offered as the next grasp (the free gripper cannot take the point the other holds).
  double min_separation = 0.08;
  void Validate() const;  // throws drape::Error naming the bad field
};

// One anchor of the garment the table is built on.
struct AnchorPoint {
  std::string label;
  Vec2 uv = Vec2::Zero();  // metres, flat pattern
};

// The score table of one garment: f(i, j) over its anchors.
class ScoreTable {
 public:
  // Throws drape::Error if a desired label is not among `anchors` or there is no pair.
  ScoreTable(std::vector<AnchorPoint> anchors, std::vector<DesiredPair> desired, const ObjectiveOptions& options);

  int size() const { return static_cast<int>(anchors_.size()); }
  const AnchorPoint& anchor(int i) const { return anchors_[i]; }
  int IndexOf(const std::string& label) const;  // -1 if absent
  // f(i, j) from the table (symmetric).
  double operator()(int i, int j) const { return table_[size_t(i) * anchors_.size() + j]; }
  // f at two arbitrary points of the pattern (what the table samples).
  double Score(const Vec2& a, const Vec2& b) const;
  // Per-point score used to colour a garment: max over desired pairs and sides of
  // exp(−σ‖x − x*‖²) (the factor one gripper contributes).
  double PointScore(const Vec2& x) const;

  struct Next {
    int anchor = -1;  // best next grasp (index), -1 if none allowed
    double f = 0;     // f(current, next)
  };
  // argmax_j f(current, j) over anchors at least min_separation from `current`.
  Next BestNext(int current) const;

  const ObjectiveOptions& options() const { return options_; }
  const std::vector<DesiredPair>& desired() const { return desired_; }

 private:
  std::vector<AnchorPoint> anchors_;
  std::vector<DesiredPair> desired_;
  std::vector<std::pair<Vec2, Vec2>> desired_uv_;
  ObjectiveOptions options_;
  std::vector<double> table_;
};

}  // namespace drape::unfolding
