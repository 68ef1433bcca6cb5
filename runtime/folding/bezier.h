// Cubic Bézier folding trajectories (paper §"Trajectory parametrization"): P0 and P3
// are the grasp point's start and target, P1 and P2 the free knot points; length by
// De Casteljau subdivision (Farin), as the paper computes l_x.
#pragma once

#include <array>
#include <vector>

#include "common/mesh.h"

namespace drape::folding {

struct CubicBezier {
  std::array<Vec3, 4> P;  // control points, metres

  // T(u) = Σ_k B_k^3(u) P_k, u in [0, 1].
  Vec3 Eval(double u) const;
  // De Casteljau split at u: the curves on [0, u] and [u, 1].
  std::array<CubicBezier, 2> Split(double u) const;
};

// The paper's initialisation: P1 = ⅔P0 + ⅓P3 + h‖P0 − P3‖e_v,
// P2 = ⅓P0 + ⅔P3 + h‖P0 − P3‖e_v (h = ⅓: equal horizontal extent between knots).
// e_v is the unit upward vertical (world y up).
CubicBezier InitialTrajectory(const Vec3& p0, const Vec3& p3, double h = 1.0 / 3, const Vec3& up = Vec3::UnitY());

struct LengthReport {
  double length = 0;  // metres, Σ chords of the pieces
  int pieces = 0;     // subdivided curves summed
};

// Arc length by recursive De Casteljau halving until every piece's control polygon
// length minus its chord is at most `tolerance` × its chord (relative tolerance;
// the sum then over-/under-shoots the true length by less than tolerance × length,
// since chord ≤ arc ≤ polygon), then l ≈ Σ chords. max_depth caps recursion.
LengthReport BezierLength(const CubicBezier& c, double tolerance = 1e-6, int max_depth = 30);

// n + 1 points at equal arc length along the curve (for gripper paths), from a
// fine polyline of `samples` segments.
std::vector<Vec3> SampleByArcLength(const CubicBezier& c, int n, int samples = 512);

}  // namespace drape::folding
