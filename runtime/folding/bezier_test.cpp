// Bézier trajectories: De Casteljau length against analytic lengths (straight line,
// a quarter-circle-like cubic) and a brute-force Gauss–Legendre integral; the paper's
// h = 1/3 initialisation; arc-length sampling.
#include "runtime/folding/bezier.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"
#include "runtime/folding/run.h"

namespace drape::folding {
namespace {

// ∫₀¹ ‖T'(u)‖ du by composite 5-point Gauss–Legendre on `pieces` intervals.
double BruteForceLength(const CubicBezier& c, int pieces = 2000) {
  const double xg[5] = {-0.9061798459386640, -0.5384693101056831, 0, 0.5384693101056831, 0.9061798459386640};
  const double wg[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                        0.2369268850561891};
  auto d = [&](double u) {
    const double v = 1 - u;
    return (3 * v * v * (c.P[1] - c.P[0]) + 6 * v * u * (c.P[2] - c.P[1]) + 3 * u * u * (c.P[3] - c.P[2])).norm();
  };
  double sum = 0;
  for (int i = 0; i < pieces; ++i) {
    const double a = static_cast<double>(i) / pieces, b = static_cast<double>(i + 1) / pieces;
    for (int k = 0; k < 5; ++k) sum += 0.5 * (b - a) * wg[k] * d(0.5 * (a + b) + 0.5 * (b - a) * xg[k]);
  }
  return sum;
}

TEST(Bezier, StraightLineLengthIsTheDistance) {
  const Vec3 a(0.1, 0.0, -0.2), b(0.6, 0.3, 0.2);
  // Evenly spaced and unevenly spaced collinear knots: the length is |b − a| either way.
  for (double t1 : {1.0 / 3, 0.05}) {
    for (double t2 : {2.0 / 3, 0.9}) {
      const CubicBezier c{{a, a + t1 * (b - a), a + t2 * (b - a), b}};
      const LengthReport rep = BezierLength(c, 1e-9);
      EXPECT_NEAR(rep.length, (b - a).norm(), 1e-12);
    }
  }
}

TEST(Bezier, QuarterCircleLikeCurveMatchesTheArcAndTheIntegral) {
  // The standard cubic approximation of a quarter circle of radius R (handles
  // k = 4/3(√2 − 1)): its radius deviates from R by at most 2.7e-4 R, so its length is
  // πR/2 to a few 1e-4 relative; the Gauss–Legendre integral is exact to 1e-12.
  const double R = 0.4, k = 4.0 / 3 * (std::sqrt(2.0) - 1);
  const CubicBezier c{{Vec3(R, 0, 0), Vec3(R, k * R, 0), Vec3(k * R, R, 0), Vec3(0, R, 0)}};
  for (double tol : {1e-3, 1e-6, 1e-9}) {
    const LengthReport rep = BezierLength(c, tol);
    const double ref = BruteForceLength(c);
    // Chord ≤ arc ≤ polygon on every piece, and polygon − chord ≤ tol·chord.
    EXPECT_LE(std::abs(rep.length - ref), tol * ref) << "tolerance " << tol << ", " << rep.pieces << " pieces";
    EXPECT_NEAR(rep.length, M_PI * R / 2, 3e-4 * M_PI * R / 2 + 1e-4 * R);
  }
  EXPECT_GT(BezierLength(c, 1e-9).pieces, BezierLength(c, 1e-3).pieces);
}

TEST(Bezier, PapersInitialisationLiftsTheThirdPointsByHTimesTheSpan) {
  const Vec3 p0(0.3, 0.01, 0.1), p3(-0.3, 0.01, 0.1);
  const CubicBezier c = InitialTrajectory(p0, p3);
  const double span = (p0 - p3).norm();
  EXPECT_TRUE(c.P[0].isApprox(p0));
  EXPECT_TRUE(c.P[3].isApprox(p3));
  EXPECT_TRUE((c.P[1] - (2 * p0 + p3) / 3).isApprox(Vec3(0, span / 3, 0), 1e-15));
  EXPECT_NEAR(c.P[1].y() - p0.y(), span / 3, 1e-15);
  EXPECT_NEAR(c.P[2].y() - p0.y(), span / 3, 1e-15);
  EXPECT_NEAR(c.P[2].x(), 0.3 - 2 * 0.6 / 3, 1e-15);
  // The curve's apex (u = ½) is at ¾ of the knots' height.
  EXPECT_NEAR(c.Eval(0.5).y() - p0.y(), 0.75 * span / 3, 1e-12);
}

TEST(Bezier, SplitReproducesTheCurve) {
  const CubicBezier c{{Vec3(0, 0, 0), Vec3(0.1, 0.3, 0), Vec3(0.5, 0.2, 0.1), Vec3(0.6, 0, 0)}};
  const auto h = c.Split(0.3);
  for (double u : {0.0, 0.25, 0.5, 1.0}) {
    EXPECT_TRUE(h[0].Eval(u).isApprox(c.Eval(0.3 * u), 1e-12));
    EXPECT_TRUE(h[1].Eval(u).isApprox(c.Eval(0.3 + 0.7 * u), 1e-12));
  }
}

TEST(Bezier, ArcLengthSamplesAreEvenlySpaced) {
  const CubicBezier c = InitialTrajectory(Vec3(0.2, 0, 0), Vec3(-0.2, 0, 0), 0.6);
  const auto pts = SampleByArcLength(c, 20, 4000);
  ASSERT_EQ(pts.size(), 21u);
  const double L = BezierLength(c).length;
  // Equal arc length between samples: chords of equal arcs, a little shorter than L/20.
  for (size_t i = 1; i < pts.size(); ++i) EXPECT_NEAR((pts[i] - pts[i - 1]).norm(), L / 20, 3e-3 * L / 20 + 1e-4 * L);
}

TEST(Bezier, RejectsNonFiniteControlPoints) {
  CubicBezier c = InitialTrajectory(Vec3(0, 0, 0), Vec3(1, 0, 0));
  c.P[1].x() = NAN;
  EXPECT_THROW(BezierLength(c), NumericalError);
}

// A trajectory relative to its fold (u: along the fold on the table, v: up, w = u × v,
// lengths over |P3 − P0|), as trials replay it from other grasp and target points.
TEST(Bezier, RelativeTrajectoryIsInTheFoldFrameAndRoundTrips) {
  const CubicBezier c{{Vec3(0.1, 0.0, 0.2), Vec3(0.15, 0.1, 0.25), Vec3(0.3, 0.12, 0.3), Vec3(0.4, 0.0, 0.35)}};
  const RelativeTrajectory r = ToRelative(c);
  const double s = std::hypot(0.3, 0.15);
  const Vec3 u = Vec3(0.3, 0, 0.15) / s, v = Vec3::UnitY(), w = u.cross(v);
  for (int k = 1; k <= 2; ++k) {
    const Vec3 d = c.P[k] - c.P[0];
    const Vec3 want = Vec3(d.dot(u), d.dot(v), d.dot(w)) / s;
    EXPECT_NEAR(((k == 1 ? r.k1 : r.k2) - want).norm(), 0, 1e-12) << "k" << k;
  }
  const CubicBezier back = FromRelative(r, c.P[0], c.P[3]);
  for (int k = 0; k < 4; ++k) EXPECT_NEAR((back.P[k] - c.P[k]).norm(), 0, 1e-12) << "P" << k;
}

}  // namespace
}  // namespace drape::folding
