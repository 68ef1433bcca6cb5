#include "runtime/folding/bezier.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"

namespace drape::folding {

Vec3 CubicBezier::Eval(double u) const {
  const double v = 1 - u;
  return v * v * v * P[0] + 3 * v * v * u * P[1] + 3 * v * u * u * P[2] + u * u * u * P[3];
}

std::array<CubicBezier, 2> CubicBezier::Split(double u) const {
  const Vec3 a = P[0] + u * (P[1] - P[0]), b = P[1] + u * (P[2] - P[1]), c = P[2] + u * (P[3] - P[2]);
  const Vec3 d = a + u * (b - a), e = b + u * (c - b);
  const Vec3 m = d + u * (e - d);
  return {CubicBezier{{P[0], a, d, m}}, CubicBezier{{m, e, c, P[3]}}};
}

CubicBezier InitialTrajectory(const Vec3& p0, const Vec3& p3, double h, const Vec3& up) {
  const Vec3 lift = h * (p0 - p3).norm() * up.normalized();
  return CubicBezier{{p0, 2.0 / 3 * p0 + 1.0 / 3 * p3 + lift, 1.0 / 3 * p0 + 2.0 / 3 * p3 + lift, p3}};
}

namespace {
void Accumulate(const CubicBezier& c, double tol, int depth, LengthReport& rep) {
  const double chord = (c.P[3] - c.P[0]).norm();
  const double polygon = (c.P[1] - c.P[0]).norm() + (c.P[2] - c.P[1]).norm() + (c.P[3] - c.P[2]).norm();
  // A degenerate piece (all points together) has chord = polygon = 0: done.
  if (polygon - chord <= tol * chord || polygon == 0 || depth <= 0) {
    rep.length += chord;
    ++rep.pieces;
    return;
  }
  const auto halves = c.Split(0.5);
  Accumulate(halves[0], tol, depth - 1, rep);
  Accumulate(halves[1], tol, depth - 1, rep);
}
}  // namespace

LengthReport BezierLength(const CubicBezier& c, double tolerance, int max_depth) {
  if (!(tolerance > 0)) throw Error("BezierLength: tolerance must be > 0");
  for (const Vec3& p : c.P)
    if (!p.allFinite()) throw NumericalError("BezierLength: non-finite control point");
  LengthReport rep;
  Accumulate(c, tolerance, max_depth, rep);
  return rep;
}

std::vector<Vec3> SampleByArcLength(const CubicBezier& c, int n, int samples) {
  DRAPE_CHECK(n >= 1 && samples >= n, "sample counts");
  std::vector<Vec3> poly(samples + 1);
  std::vector<double> s(samples + 1, 0.0);
  for (int i = 0; i <= samples; ++i) {
    poly[i] = c.Eval(static_cast<double>(i) / samples);
    if (i) s[i] = s[i - 1] + (poly[i] - poly[i - 1]).norm();
  }
  std::vector<Vec3> out(n + 1);
  out[0] = c.P[0];
  out[n] = c.P[3];
  int seg = 0;
  for (int k = 1; k < n; ++k) {
    const double target = s[samples] * k / n;
    while (seg < samples - 1 && s[seg + 1] < target) ++seg;
    const double len = s[seg + 1] - s[seg];
    const double t = len > 0 ? (target - s[seg]) / len : 0;
    out[k] = poly[seg] + t * (poly[seg + 1] - poly[seg]);
  }
  return out;
}

}  // namespace drape::folding
