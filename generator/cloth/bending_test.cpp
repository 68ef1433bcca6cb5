// Hinge bending: the dihedral angle and its gradient against finite differences, the
// forces against finite differences of the energy, the energy of a bent sheet against
// the continuum's (B/2)·κ² per area, rest angles of a stitched two-layer garment, and
// plasticity (a fold held past the yield keeps part of its angle).
#include "generator/cloth/bending.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "common/error.h"
#include "common/rng.h"
#include "generator/cloth/rectangle.h"

namespace drape {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(Bending, DihedralAngleIsZeroFlatAndSignedWhenFolded) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0.5, 1, 0), d(0.5, -1, 0);
  EXPECT_NEAR(DihedralAngle(a, b, c, d), 0, 1e-15);
  // Face (b, a, d) turned down (away from the normal of face (a, b, c)) by 60°: +60°;
  // turned up: −60°.
  const double t = kPi / 3;
  const Vec3 d60(0.5, -std::cos(t), -std::sin(t));
  EXPECT_NEAR(DihedralAngle(a, b, c, d60), t, 1e-12);
  const Vec3 d_up(0.5, -std::cos(t), std::sin(t));
  EXPECT_NEAR(DihedralAngle(a, b, c, d_up), -t, 1e-12);
  // Folded onto each other: ±π.
  EXPECT_NEAR(std::abs(DihedralAngle(a, b, c, Vec3(0.5, 1, 1e-9))), kPi, 1e-8);
  // The same hinge described from its other face, or turned as a whole: the same angle.
  EXPECT_NEAR(DihedralAngle(b, a, d60, c), t, 1e-12);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_NEAR(DihedralAngle(R * a, R * b, R * c, R * d60), t, 1e-12);
}

TEST(Bending, WrapAngleIsInMinusPiToPi) {
  EXPECT_DOUBLE_EQ(WrapAngle(0.5), 0.5);
  EXPECT_NEAR(WrapAngle(3 * kPi / 2), -kPi / 2, 1e-15);
  EXPECT_NEAR(WrapAngle(-3 * kPi / 2), kPi / 2, 1e-15);
  EXPECT_DOUBLE_EQ(WrapAngle(-kPi), kPi);
  EXPECT_DOUBLE_EQ(WrapAngle(kPi), kPi);
}

// The one-turn shortcut gives std::remainder's value bit for bit, at the branch edges
// and across several turns.
TEST(Bending, WrapAngleIsTheRemainderBitForBit) {
  auto reference = [](double a) {
    a = std::remainder(a, 2 * kPi);
    return a <= -kPi ? a + 2 * kPi : a;
  };
  std::vector<double> angles;
  for (const double edge : {kPi, 2 * kPi, 3 * kPi})
    for (const double sign : {-1.0, 1.0})
      for (int ulps = -3; ulps <= 3; ++ulps) {
        double a = sign * edge;
        for (int k = 0; k < std::abs(ulps); ++k) a = std::nextafter(a, ulps > 0 ? 10.0 : -10.0);
        angles.push_back(a);
      }
  Rng rng(11);
  for (int i = 0; i < 100000; ++i) angles.push_back(rng.Uniform(-7 * kPi, 7 * kPi));
  for (const double a : angles) {
    const double got = WrapAngle(a), want = reference(a);
    ASSERT_EQ(std::bit_cast<std::uint64_t>(got), std::bit_cast<std::uint64_t>(want))
        << "angle " << a << ": " << got << " against " << want;
  }
}

TEST(Bending, GradientMatchesFiniteDifferences) {
  Rng rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    std::array<Vec3, 4> p;
    for (auto& q : p) q = Vec3(rng.Uniform(-1, 1), rng.Uniform(-1, 1), rng.Uniform(-1, 1));
    double theta = 0;
    std::array<Vec3, 4> g;
    ASSERT_TRUE(DihedralAngleGradient(p[0], p[1], p[2], p[3], &theta, &g));
    if (std::abs(theta) > 3.0) continue;  // near ±π the difference quotient straddles the cut
    const double h = 1e-6;
    for (int i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) {
        auto q = p;
        q[i][c] += h;
        const double up = DihedralAngle(q[0], q[1], q[2], q[3]);
        q[i][c] -= 2 * h;
        const double down = DihedralAngle(q[0], q[1], q[2], q[3]);
        EXPECT_NEAR((up - down) / (2 * h), g[i][c], 1e-5 * (1 + std::abs(g[i][c]))) << trial << " " << i << c;
      }
    // Translations and rotations leave θ alone: Σ g = 0.
    EXPECT_LT((g[0] + g[1] + g[2] + g[3]).norm(), 1e-9 * (g[2].norm() + g[3].norm()));
  }
}

// A small sheet, deformed, with rest angles away from the current angles.
struct Bent {
  TriMesh rest;
  Points3 x;
};
Bent BentSheet() {
  const Garment g = MakeRectangleGarment(0.1, 0.12, 0.02, false);
  Bent s{g.mesh, g.mesh.V};
  for (int i = 0; i < s.x.rows(); ++i) {
    const double u = s.x(i, 0), v = s.x(i, 1);
    s.x(i, 2) += 0.02 * std::sin(20 * u + 7 * v) + 0.01 * std::cos(31 * v);
    s.x(i, 0) += 0.002 * std::sin(40 * v);
  }
  // Rest: another bent shape, so rest angles are not zero.
  for (int i = 0; i < s.rest.V.rows(); ++i) s.rest.V(i, 2) = 0.01 * std::sin(25 * s.rest.V(i, 1));
  return s;
}

TEST(Bending, ForcesAreMinusTheEnergyGradient) {
  const Bent s = BentSheet();
  BendingOptions o;
  o.rigidity = 2.3e-5;
  const BendingModel m = MakeBendingModel(s.rest, {}, o);
  ASSERT_GT(m.hinges.size(), 50u);
  EXPECT_GT(m.rest_angle.cwiseAbs().maxCoeff(), 0.05);
  const BendingState st = InitialBendingState(m);
  Points3 f = Points3::Zero(s.x.rows(), 3);
  AddBendingForces(m, st, s.x, f);
  const double h = 1e-7;
  double worst = 0;
  for (int i = 0; i < s.x.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      Points3 y = s.x;
      y(i, c) += h;
      const double up = BendingEnergy(m, st, y);
      y(i, c) -= 2 * h;
      const double down = BendingEnergy(m, st, y);
      const double fd = -(up - down) / (2 * h);
      worst = std::max(worst, std::abs(fd - f(i, c)));
    }
  EXPECT_LT(worst, 1e-6 * f.cwiseAbs().maxCoeff());
  EXPECT_GT(f.cwiseAbs().maxCoeff(), 1e-5);
}

// An equilateral lattice of side s, n×m points, in the x–y plane.
TriMesh Lattice(double s, int n, int m) {
  TriMesh t;
  t.V.resize(Eigen::Index{n} * m, 3);
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) t.V.row(j * n + i) << s * (i + 0.5 * (j % 2)), s * j * std::sqrt(3.0) / 2, 0;
  std::vector<std::array<int, 3>> f;
  for (int j = 0; j + 1 < m; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      if (j % 2 == 0) {
        f.push_back({a, b, c});
        f.push_back({b, d, c});
      } else {
        f.push_back({a, b, d});
        f.push_back({a, d, c});
      }
    }
  t.F.resize(static_cast<int>(f.size()), 3);
  for (size_t k = 0; k < f.size(); ++k) t.F.row(static_cast<int>(k)) << f[k][0], f[k][1], f[k][2];
  return t;
}

// The continuum holds (B/2)·κ² per area of a sheet bent into a cylinder of curvature κ.
// The lattice holds, per hinge, that energy density times the area per edge, s²/(2√3),
// for every direction of the cylinder's axis (with C = 1).
TEST(Bending, EquilateralLatticeOnACylinderHoldsTheContinuumEnergy) {
  const double s = 0.01, B = 3e-5, kappa = 20;
  const TriMesh flat = Lattice(s, 40, 40);
  BendingOptions o;
  o.rigidity = B;
  const BendingModel m = MakeBendingModel(flat, {}, o);
  const BendingState st = InitialBendingState(m);
  const Vec3 centre = flat.V.colwise().mean().transpose();
  for (const double axis_deg : {0.0, 17.0, 30.0, 45.0, 90.0}) {
    const double t = axis_deg * kPi / 180;
    const Vec3 ax(std::cos(t), std::sin(t), 0), across(-std::sin(t), std::cos(t), 0);
    Points3 x = flat.V;
    for (int i = 0; i < x.rows(); ++i) {
      const Vec3 p = flat.V.row(i).transpose() - centre;
      const double u = p.dot(across), phi = kappa * u;
      const Vec3 q = p.dot(ax) * ax + std::sin(phi) / kappa * across + Vec3(0, 0, (1 - std::cos(phi)) / kappa);
      x.row(i) = q.transpose();
    }
    const double per_hinge = BendingEnergy(m, st, x) / static_cast<double>(m.hinges.size());
    const double expected = 0.5 * B * kappa * kappa * s * s / (2 * std::sqrt(3.0));
    EXPECT_NEAR(per_hinge / expected, 1.0, 0.01) << "axis " << axis_deg << "°";
  }
}

TEST(Bending, StitchedLayersRestFoldedAndEverythingElseFlat) {
  const Garment g = MakeRectangleGarment(0.2, 0.2, 0.04, true);
  BendingOptions o;
  o.rigidity = 1e-5;
  const BendingModel m = MakeBendingModel(g.mesh, g.layer, o);
  int folded = 0;
  for (size_t h = 0; h < m.hinges.size(); ++h) {
    const double r = m.rest_angle[static_cast<int>(h)];
    EXPECT_TRUE(r == 0 || std::abs(r) == kPi);
    folded += r != 0;
  }
  EXPECT_EQ(folded, 5 + 5 + 5);  // the left, right and bottom seams, 5 edges each
  // The flat two-layer pattern lies near its rest: only the seam hinges hold energy.
  const BendingState st = InitialBendingState(m);
  Points3 x = g.mesh.V;
  x.col(2).setZero();  // layers pressed together: the seam folds close to π
  EXPECT_LT(BendingEnergy(m, st, x), BendingEnergy(m, st, g.mesh.V) + 1e-12);
}

TEST(Bending, RejectsBadOptionsAndInconsistentOrientation) {
  const Garment g = MakeRectangleGarment(0.1, 0.1, 0.05, false);
  BendingOptions o;
  o.rigidity = -1;
  EXPECT_THROW(MakeBendingModel(g.mesh, {}, o), Error);
  o.rigidity = 1e-5;
  o.scale = 0;
  EXPECT_THROW(MakeBendingModel(g.mesh, {}, o), Error);
  o.scale = 1;
  TriMesh flipped = g.mesh;
  std::swap(flipped.F(0, 1), flipped.F(0, 2));
  EXPECT_THROW(MakeBendingModel(flipped, {}, o), Error);
  EXPECT_THROW(MakeBendingModel(g.mesh, {0, 1}, o), Error);
}

// A sheet folded by 90° along one row of hinges and held there: with a yield curvature
// below the fold's, the rest angles of the folded row move towards the fold; below the
// yield nothing changes.
TEST(Bending, AFoldPastTheYieldKeepsPartOfItsAngle) {
  const TriMesh flat = Lattice(0.01, 12, 12);
  for (const double yield : {50.0, 1e4}) {
    BendingOptions o;
    o.rigidity = 1e-5;
    o.yield_curvature = yield;
    o.weakening = 1;
    const BendingModel m = MakeBendingModel(flat, {}, o);
    BendingState st = InitialBendingState(m);
    // Fold about the line y = y0 by 90°.
    const Eigen::Index row6 = Eigen::Index{6} * 12;  // the first node of lattice row 6
    const double y0 = flat.V(row6, 1) + 0.25 * 0.01;
    Points3 x = flat.V;
    for (int i = 0; i < x.rows(); ++i)
      if (x(i, 1) > y0) {
        const double d = x(i, 1) - y0;
        x(i, 1) = y0;
        x(i, 2) = d;
      }
    const int yielded = UpdatePlasticity(m, st, x);
    double largest = 0;
    for (int h = 0; h < st.rest_angle.size(); ++h) largest = std::max(largest, std::abs(st.rest_angle[h]));
    if (yield < 100) {
      EXPECT_GT(yielded, 10);
      EXPECT_GT(largest, 0.5);      // rad: part of the 90° fold stays
      EXPECT_LT(largest, kPi / 2);  // not all of it: the elastic part springs back
      EXPECT_GT(st.damage.maxCoeff(), 0);
      // Held there again, nothing more yields: the state is on the yield surface.
      EXPECT_EQ(UpdatePlasticity(m, st, x), 0);
    } else {
      EXPECT_EQ(yielded, 0);
      EXPECT_EQ(largest, 0);
    }
  }
}

}  // namespace
}  // namespace drape
