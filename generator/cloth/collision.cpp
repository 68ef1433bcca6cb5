#include "generator/cloth/collision.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>

#include "common/error.h"
#include "common/timing.h"

namespace drape {
namespace {

// Seconds since t0, a ClockSeconds() taken earlier: the phases' timing (steady clock, cheap
// to read; the caller scales a run's sum to its thread CPU time, see CollisionReport).
double ClockSince(double t0) { return ClockSeconds() - t0; }

constexpr double kTiny = 1e-30;               // m²: below this a segment has zero length
constexpr double kAccdShrink = 0.1;           // ACCD's s: report below s × min(initial gap, ξ) (AdditiveCCD)
constexpr int kAccdMaxSteps = 2000;           // ACCD step cap; hitting it reports a collision
constexpr double kMaxZoneAngle = 1.5;         // rad per step: keeps (1−t)I + tR invertible
constexpr double kReuseMargin = 1.25;         // × thickness: broad-phase superset margin (BroadPhase::SetReuseMargin)
constexpr double kRigidTolerance = 1e-7;      // m: kinematic nodes further off a rigid fit are non-rigid
constexpr long long kRepelSnapshotCalls = 4;  // Apply calls between repulsion snapshots
// m: what a skipped repulsion pair must have to spare beyond thickness, far above the
// closest-point routines' error (rounding; their near-parallel and near-degenerate
// fallbacks are off the exact distance by at most ~1e-7 × an edge length: ~1e-8 m for
// edges of 10 cm).
constexpr double kRepelSkipMargin = 1e-6;
// The strain clamp's squared-length test (LimitStrain): squared bounds pulled in by these.
constexpr double kSquaredBelow = 1 - 1e-12, kSquaredAbove = 1 + 1e-12;

// ---------------------------------------------------------------------------------
// Pairs: a VF pair (vertex, face) or an EE pair (edge, edge) as four node indices and
// the coefficients c of their closest points: Σ c_k x_k is the vector from the second
// element's closest point to the first's.
struct Stencil {
  std::array<int, 4> n;
  bool vf;
};
using Quad = std::array<Vec3, 4>;
using Coeffs = std::array<double, 4>;

Quad Gather(const Stencil& s, const Points3& x) {
  return {x.row(s.n[0]).transpose(), x.row(s.n[1]).transpose(), x.row(s.n[2]).transpose(), x.row(s.n[3]).transpose()};
}
Quad Lerp(const Quad& a, const Quad& b, double t) {
  Quad q;
  for (int k = 0; k < 4; ++k) q[k] = a[k] + t * (b[k] - a[k]);
  return q;
}

// Squared distance and closest-point coefficients of a pair in configuration q.
double Closest(bool vf, const Quad& q, Coeffs* c) {
  if (vf) {
    Vec3 w;
    const double d2 = PointTriangleDistanceSquared(q[0], q[1], q[2], q[3], c ? &w : nullptr);
    if (c) *c = {1.0, -w[0], -w[1], -w[2]};
    return d2;
  }
  double s = 0, t = 0;
  const double d2 = SegmentSegmentDistanceSquared(q[0], q[1], q[2], q[3], &s, &t);
  if (c) *c = {1 - s, s, -(1 - t), -t};
  return d2;
}

// Whether the pair in configuration q is surely at least `reach` apart (the cheap bounds
// of collision.h).
bool SurelyFarther(bool vf, const Quad& q, double reach) {
  return vf ? PointTriangleSurelyFarther(q[0], q[1], q[2], q[3], reach)
            : SegmentSegmentSurelyFarther(q[0], q[1], q[2], q[3], reach);
}

Vec3 Combine(const Coeffs& c, const Quad& q) { return c[0] * q[0] + c[1] * q[1] + c[2] * q[2] + c[3] * q[3]; }

// Changes the relative vector Σ c_k x_k by `delta`, split by inverse mass (Bridson
// §7.1's weighted impulse). False when every node of the pair is kinematic.
bool ShiftRelative(const Stencil& s, const Coeffs& c, const Vec3& delta, const Eigen::VectorXd& inv_mass, Points3& x1) {
  double denom = 0;
  for (int k = 0; k < 4; ++k) denom += c[k] * c[k] * inv_mass[s.n[k]];
  if (!(denom > 0)) return false;
  for (int k = 0; k < 4; ++k) {
    const double f = c[k] * inv_mass[s.n[k]] / denom;
    if (f != 0) x1.row(s.n[k]) += f * delta.transpose();
  }
  return true;
}

// Cloth–cloth Coulomb friction after a normal correction of `dn` (m) along n: it slows
// the pair's relative tangential motion over the step (from x0, Bridson §7.2) by at most
// μ·dn, and, given friction_from (Apply's), never by more than brings it to rest at the
// step's end either (motion from there). With sub-steps the two differ; friction on the
// mean alone reversed and sped up a mode that turns within the step.
void PairFriction(const Stencil& s, const Coeffs& c, const Vec3& n, double dn, double mu, const Points3& x0,
                  const Points3* friction_from, const Eigen::VectorXd& inv_mass, Points3& x1) {
  if (!(mu > 0 && dn > 0)) return;
  const Vec3 at = Combine(c, Gather(s, x1));
  const Vec3 rel = at - Combine(c, Gather(s, x0));
  const Vec3 rt = rel - rel.dot(n) * n;
  const double lt = rt.norm();
  if (lt <= 0) return;
  double slow = std::min(lt, mu * dn);
  if (friction_from) slow = std::min(slow, std::max(0.0, (at - Combine(c, Gather(s, *friction_from))).dot(rt) / lt));
  if (slow > 0) ShiftRelative(s, c, -rt * (slow / lt), inv_mass, x1);
}

// True when the pair's two elements in configuration q are surely at least d (m)
// apart, from the triangle's plane or the edges' lines (collision.h), then their
// bounding boxes, then their bounding spheres (no closest-point search); d is grown by
// a relative 1e-9 against rounding.
bool ApartBeyond(bool vf, const Quad& q, double d) {
  d *= 1 + 1e-9;
  if (SurelyFarther(vf, q, d)) return true;
  const int split = vf ? 1 : 2;  // q[0, split): first element, q[split, 4): second
  Vec3 alo = q[0], ahi = q[0], blo = q[split], bhi = q[split];
  for (int k = 1; k < 4; ++k) {
    if (k == split) continue;
    Vec3 &lo = k < split ? alo : blo, &hi = k < split ? ahi : bhi;
    lo = lo.cwiseMin(q[k]);
    hi = hi.cwiseMax(q[k]);
  }
  if ((blo - ahi).cwiseMax(alo - bhi).cwiseMax(0.0).squaredNorm() >= d * d) return true;
  Vec3 ca = Vec3::Zero(), cb = Vec3::Zero();
  for (int k = 0; k < 4; ++k) (k < split ? ca : cb) += q[k];
  ca /= split;
  cb /= 4 - split;
  double ra2 = 0, rb2 = 0;
  for (int k = 0; k < split; ++k) ra2 = std::max(ra2, (q[k] - ca).squaredNorm());
  for (int k = split; k < 4; ++k) rb2 = std::max(rb2, (q[k] - cb).squaredNorm());
  const double reach = d + std::sqrt(ra2) + std::sqrt(rb2);
  return (ca - cb).squaredNorm() >= reach * reach;
}

// ---------------------------------------------------------------------------------
// Additive CCD (Li, Kaufman & Jiang 2021, Algorithm 1) on the straight path q0 → q1.
// d0_memo (optional): the pair's distance at q0 when known (NaN: not yet, then stored):
// the same value the closest points give, for a pair tested again on the same q0.
bool AdditiveCCD(bool vf, const Quad& q0, const Quad& q1, double min_separation, double* toi,
                 double* d0_memo = nullptr) {
  Quad p;
  Vec3 mean = Vec3::Zero();
  for (int k = 0; k < 4; ++k) {
    p[k] = q1[k] - q0[k];
    mean += 0.25 * p[k];
  }
  for (auto& v : p) v -= mean;
  // l_p bounds |relative displacement of the closest points| over the whole path.
  // (The root of the largest squared norm is the largest norm, bit for bit: the root is
  // rounded correctly and never decreasing; two roots instead of four.)
  const double lp = vf ? std::sqrt(p[0].squaredNorm()) +
                             std::sqrt(std::max({p[1].squaredNorm(), p[2].squaredNorm(), p[3].squaredNorm()}))
                       : std::sqrt(std::max(p[0].squaredNorm(), p[1].squaredNorm())) +
                             std::sqrt(std::max(p[2].squaredNorm(), p[3].squaredNorm()));
  // The first test below (tl >= 1, i.e. lp <= 0.9·(d0 − ξ)) on a lower bound of d0,
  // without the closest points: the same answer for the many candidates that are far
  // apart for their motion.
  if (ApartBeyond(vf, q0, min_separation + lp / (1 - kAccdShrink))) return false;
  double d0;
  if (d0_memo && !std::isnan(*d0_memo)) {
    d0 = *d0_memo;
  } else {
    d0 = std::sqrt(Closest(vf, q0, nullptr));
    if (d0_memo) *d0_memo = d0;
  }
  if (!(d0 > 0)) {  // touching at the start (or NaN): conservative
    *toi = 0;
    return true;
  }
  if (lp <= 0) return false;
  const double xi = std::min(min_separation, 0.5 * d0);
  const double gap0 = d0 - xi;
  // Reported when the gap falls below s × the smaller of the initial gap and ξ, i.e. only
  // within (1 + s)·ξ of touching. Li et al.'s s × initial gap (a line search's safe step)
  // reported a pair 5 cm apart that closed to 7 mm as an impact, so which candidate pairs
  // the CCD was given decided contacts: a folded towel's flap landed on such impacts and
  // slid open (18 of 30 folds held against 26 of 30 with this bound; docs/simulation.md).
  const double g = kAccdShrink * std::min(gap0, xi);
  double tl = (1 - kAccdShrink) * gap0 / lp;
  if (tl >= 1) return false;  // the distance cannot drop by gap0 over the path
  double t = 0;
  for (int step = 0; step < kAccdMaxSteps; ++step) {
    const double d = std::sqrt(Closest(vf, Lerp(q0, q1, t + tl), nullptr));
    if (t > 0 && d - xi < g) break;
    t += tl;
    if (t >= 1) return false;
    tl = 0.9 * (d - xi) / lp;
  }
  *toi = t;
  return true;
}

std::vector<std::array<int, 2>> MeshEdges(const Faces& F, const Points3& x) {
  TriMesh m;
  m.F = F;
  m.V = x;
  return UniqueEdges(m);
}

double MeanEdgeLength(const std::vector<std::array<int, 2>>& E, const Points3& x) {
  double sum = 0;
  for (const auto& e : E) sum += (x.row(e[0]) - x.row(e[1])).norm();
  return E.empty() ? 0 : sum / double(E.size());
}

// ---------------------------------------------------------------------------------
// Rigid motions for impact zones.
struct Rigid {
  Vec3 c0 = Vec3::Zero(), c1 = Vec3::Zero();  // x ↦ c1 + R (x − c0)
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
};

Eigen::Matrix3d RotationFromVector(Vec3 theta) {
  const double angle = theta.norm();
  if (!(angle > 0)) return Eigen::Matrix3d::Identity();
  if (angle > kMaxZoneAngle) theta *= kMaxZoneAngle / angle;
  return Eigen::AngleAxisd(theta.norm(), theta.normalized()).toRotationMatrix();
}

// The rigid motion that conserves the zone's linear and angular momentum; positions
// x0, proposed xin (velocities (xin − x0)/dt, dt cancels).
Rigid MomentumRigid(const std::vector<int>& zone, const Points3& x0, const Points3& xin,
                    const Eigen::VectorXd& inv_mass) {
  double mass = 0;
  Vec3 c = Vec3::Zero(), d = Vec3::Zero();
  for (int i : zone) {
    const double m = 1.0 / inv_mass[i];
    mass += m;
    c += m * x0.row(i).transpose();
    d += m * (xin.row(i) - x0.row(i)).transpose();
  }
  c /= mass;
  d /= mass;
  Vec3 L = Vec3::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
  for (int i : zone) {
    const double m = 1.0 / inv_mass[i];
    const Vec3 r = x0.row(i).transpose() - c;
    L += m * r.cross((xin.row(i) - x0.row(i)).transpose() - d);
    I += m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  Rigid out;
  out.c0 = c;
  out.c1 = c + d;
  // Pseudo-inverse: a collinear zone has no inertia (and no momentum) about its line.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(I, Eigen::ComputeFullU | Eigen::ComputeFullV);
  svd.setThreshold(1e-12);
  out.R = RotationFromVector(svd.solve(L));
  return out;
}

// Best rigid fit (Kabsch) of the kinematic nodes' prescribed motion x0 → x1.
Rigid KinematicRigid(const std::vector<int>& nodes, const Points3& x0, const Points3& x1) {
  Rigid out;
  for (int i : nodes) {
    out.c0 += x0.row(i).transpose();
    out.c1 += x1.row(i).transpose();
  }
  out.c0 /= double(nodes.size());
  out.c1 /= double(nodes.size());
  if (nodes.size() < 2) return out;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (int i : nodes) H += (x0.row(i).transpose() - out.c0) * (x1.row(i).transpose() - out.c1).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3& s = svd.singularValues();
  if (!(s[0] > 0)) return out;
  if (s[1] <= 1e-9 * s[0]) {  // collinear: the smallest rotation taking the line to the line
    const Vec3 a = svd.matrixU().col(0), b = svd.matrixV().col(0);
    out.R = Eigen::Quaterniond::FromTwoVectors(a, b).toRotationMatrix();
    return out;
  }
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  out.R = svd.matrixV() * D * svd.matrixU().transpose();
  return out;
}

// Disjoint sets over nodes, for merging impact zones.
class UnionFind {
 public:
  explicit UnionFind(int n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int Find(int a) {
    while (parent_[a] != a) a = parent_[a] = parent_[parent_[a]];
    return a;
  }
  void Unite(int a, int b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<int> parent_;
};

}  // namespace

// ===================================================================================
// Primitives.

double PointTriangleDistanceSquared(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3* w) {
  // Ericson, Real-Time Collision Detection §5.1.5, returning barycentric weights.
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  Vec3 bary;
  // Zero-area (or nearly) triangles: the nearest of the three edges.
  if (!(ab.cross(ac).squaredNorm() > 1e-12 * ab.squaredNorm() * ac.squaredNorm())) {
    double best = std::numeric_limits<double>::infinity();
    const Vec3* pts[3] = {&a, &b, &c};
    for (int k = 0; k < 3; ++k) {
      double s = 0, t = 0;
      const double d = SegmentSegmentDistanceSquared(p, p, *pts[k], *pts[(k + 1) % 3], &s, &t);
      if (d < best) {
        best = d;
        bary.setZero();
        bary[k] = 1 - t;
        bary[(k + 1) % 3] += t;
      }
    }
    if (w) *w = bary;
    return best;
  }
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  const Vec3 bp = p - b, cp = p - c;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp), d5 = ab.dot(cp), d6 = ac.dot(cp);
  const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
  if (d1 <= 0 && d2 <= 0) {
    bary = {1, 0, 0};
  } else if (d3 >= 0 && d4 <= d3) {
    bary = {0, 1, 0};
  } else if (vc <= 0 && d1 >= 0 && d3 <= 0 && d1 - d3 > 0) {
    const double v = d1 / (d1 - d3);
    bary = {1 - v, v, 0};
  } else if (d6 >= 0 && d5 <= d6) {
    bary = {0, 0, 1};
  } else if (vb <= 0 && d2 >= 0 && d6 <= 0 && d2 - d6 > 0) {
    const double v = d2 / (d2 - d6);
    bary = {1 - v, 0, v};
  } else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0 && (d4 - d3) + (d5 - d6) > 0) {
    const double v = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    bary = {0, 1 - v, v};
  } else {
    const double v = vb / (va + vb + vc), u = vc / (va + vb + vc);
    bary = {1 - v - u, v, u};
  }
  if (w) *w = bary;
  return (p - (bary[0] * a + bary[1] * b + bary[2] * c)).squaredNorm();
}

double SegmentSegmentDistanceSquared(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, double* s_out,
                                     double* t_out) {
  // Ericson §5.1.9, with a relative parallelism test.
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0, t = 0;
  if (a <= kTiny && e <= kTiny) {
    s = t = 0;
  } else if (a <= kTiny) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= kTiny) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  if (s_out) *s_out = s;
  if (t_out) *t_out = t;
  return ((p0 + s * d1) - (q0 + t * d2)).squaredNorm();
}

namespace {
// |n·d| ≥ reach·|n| compared squared, for n = u × v; false when |u × v| is below 1e-3 of |u||v|.
bool FartherAlong(const Vec3& u, const Vec3& v, const Vec3& d, double reach) {
  const Vec3 n = u.cross(v);
  const double n2 = n.squaredNorm(), along = n.dot(d);
  return n2 > 1e-6 * u.squaredNorm() * v.squaredNorm() && along * along >= reach * reach * n2;
}
}  // namespace

bool PointTriangleSurelyFarther(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double reach) {
  return FartherAlong(b - a, c - a, p - a, reach);
}

bool SegmentSegmentSurelyFarther(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, double reach) {
  return FartherAlong(p1 - p0, q1 - q0, q0 - p0, reach);
}

bool VertexTriangleCCD(const Vec3& p0, const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& p1, const Vec3& a1,
                       const Vec3& b1, const Vec3& c1, double min_separation, double* toi) {
  double t = 0;
  const bool hit = AdditiveCCD(true, {p0, a0, b0, c0}, {p1, a1, b1, c1}, min_separation, &t);
  if (hit && toi) *toi = t;
  return hit;
}

bool EdgeEdgeCCD(const Vec3& pa0, const Vec3& pb0, const Vec3& qa0, const Vec3& qb0, const Vec3& pa1, const Vec3& pb1,
                 const Vec3& qa1, const Vec3& qb1, double min_separation, double* toi) {
  double t = 0;
  const bool hit = AdditiveCCD(false, {pa0, pb0, qa0, qb0}, {pa1, pb1, qa1, qb1}, min_separation, &t);
  if (hit && toi) *toi = t;
  return hit;
}

double MinimumNonAdjacentDistance(const Faces& F, const Points3& x) {
  const auto E = MeshEdges(F, x);
  if (F.rows() == 0 || x.rows() == 0) return std::numeric_limits<double>::infinity();
  const double cell = std::max(MeanEdgeLength(E, x), 1e-6);
  const Vec3 extent = x.colwise().maxCoeff() - x.colwise().minCoeff();
  BroadPhase broad(F, E, x);
  std::vector<Aabb> boxes;
  CandidatePairs cand;
  // Grow the search radius r until some pair lies within it: every pair closer than
  // r has overlapping boxes when each is padded by r/2.
  for (double r = 0.25 * cell;; r *= 4) {
    SweptVertexBoxes(x, x, 0.5 * r, &boxes);
    broad.Find(boxes, &cand);
    double best = std::numeric_limits<double>::infinity();
    for (const auto& [v, f] : cand.vf)
      best = std::min(best, PointTriangleDistanceSquared(x.row(v), x.row(F(f, 0)), x.row(F(f, 1)), x.row(F(f, 2))));
    for (const auto& [a, b] : cand.ee)
      best =
          std::min(best, SegmentSegmentDistanceSquared(x.row(E[a][0]), x.row(E[a][1]), x.row(E[b][0]), x.row(E[b][1])));
    best = std::sqrt(best);
    if (best <= r) return best;
    if (r > 2 * extent.norm()) return best;  // every pair was a candidate
  }
}

// ===================================================================================
// Options.

void BoxCollider::Validate() const {
  auto bad = [](const char* field, const std::string& what) {
    throw Error(std::string("collision: BoxCollider.") + field + " " + what);
  };
  if (!pose.matrix().allFinite()) bad("pose", "must be finite");
  if (!((pose.linear().transpose() * pose.linear() - Eigen::Matrix3d::Identity()).norm() < 1e-6))
    bad("pose", "must be a rigid transform (orthonormal rotation)");
  if (!(half_extents.array() > 0).all() || !half_extents.allFinite()) bad("half_extents", "must be > 0 m");
  if (!(friction >= 0 && friction <= 10)) bad("friction", "must be in [0, 10]");
}

void CollisionOptions::Validate() const {
  auto bad = [](const char* field, const std::string& what) {
    throw Error(std::string("collision: ") + field + " " + what);
  };
  if (!(thickness > 0 && thickness < 0.1)) bad("thickness", "must be in (0, 0.1) m");
  if (!(min_separation > 0 && min_separation < thickness)) bad("min_separation", "must be in (0, thickness) m");
  if (!(repulsion_fraction > 0 && repulsion_fraction <= 1)) bad("repulsion_fraction", "must be in (0, 1]");
  if (!(max_strain < 10)) bad("max_strain", "must be < 10 (≤ 0: off)");
  if (!(max_compression >= 0 && max_compression < 1)) bad("max_compression", "must be in [0, 1)");
  if (strain_iterations < 0 || strain_iterations > 10000) bad("strain_iterations", "must be in [0, 10000]");
  if (!(strain_tolerance >= 0 && strain_tolerance < 1)) bad("strain_tolerance", "must be in [0, 1)");
  if (strain_rounds < 0 || strain_rounds > 100) bad("strain_rounds", "must be in [0, 100]");
  if (!(strain_lead_weight >= 0 && strain_lead_weight <= 1)) bad("strain_lead_weight", "must be in [0, 1]");
  if (proximity_iterations < 0 || proximity_iterations > 100) bad("proximity_iterations", "must be in [0, 100]");
  if (ccd_iterations < 0 || ccd_iterations > 1000) bad("ccd_iterations", "must be in [0, 1000]");
  if (max_zone_iterations < 0 || max_zone_iterations > 100000) bad("max_zone_iterations", "must be in [0, 100000]");
  if (!(cloth_friction >= 0 && cloth_friction <= 10)) bad("cloth_friction", "must be in [0, 10]");
}

// ===================================================================================
// One Apply call.
namespace {

// std::array's == compiles to a call of memcmp here.
bool SamePair(const std::array<int, 2>& a, const std::array<int, 2>& b) {
  return int(a[0] == b[0]) & int(a[1] == b[1]);
}

struct Hit {
  Stencil s;
  double toi;
};

struct ApplyContext {
  const Faces& F;
  const std::vector<std::array<int, 2>>& E;
  const Points3& rest;
  const CollisionOptions& opt;
  const Points3& x0;
  const Points3* friction_from;  // Apply's (null: none)
  Points3& x1;
  const Eigen::VectorXd& inv_mass;
  const Eigen::VectorXd& rest_lengths;  // m, per edge of E
  const std::vector<int>& adj_start;    // vertex → neighbours (CSR)
  const std::vector<int>& adj;
  double dt;
  CollisionReport& rep;
  BroadPhase& broad;
  CollisionHandler::StrainOrder& strain_order;
  CollisionHandler::RepelSnapshot& repel_snapshot;
  CandidatePairs near = {};            // repulsion's pairs: within thickness somewhere on x0 → x1
  std::vector<Aabb> near_boxes = {};   // the path boxes they were found for (empty: none yet)
  std::vector<Aabb> fresh_boxes = {};  // the CCD's path boxes (scratch)
  CandidatePairs cand = {}, next = {};
  Points3 box_ref = {};  // the x1 the candidates were found for
  bool have_cand = false;
  // Detect's results per candidate for the x1 in detect_ref (toi < 0: no hit; NaN:
  // not known), reused for pairs none of whose nodes moved since.
  std::vector<double> cand_toi = {}, next_toi = {};
  // Per candidate: its distance at x0 (NaN: not measured yet). x0 is fixed for the call,
  // so a pair's distance there, once measured, is reused by every later test.
  std::vector<double> cand_d0 = {}, next_d0 = {};
  Points3 detect_ref = {};
  std::vector<char> dirty = {};
  bool shortcuts = true;  // CollisionHandler::SetShortcuts

  // cand_toi for the pairs of `next`: the known results of pairs also in `cand` (both
  // lists sorted), NaN for the others. A kept result stays valid: it was found for the
  // positions in detect_ref, and Detect retests a pair whose nodes moved since.
  // cand_d0 likewise (a distance at x0 stays valid for the whole call).
  void CarryResults() {
    const size_t size = next.vf.size() + next.ee.size();
    next_toi.assign(size, std::numeric_limits<double>::quiet_NaN());
    next_d0.assign(size, std::numeric_limits<double>::quiet_NaN());
    if (have_cand) {
      auto carry = [](const std::vector<std::array<int, 2>>& from, const double* from_toi, const double* from_d0,
                      const std::vector<std::array<int, 2>>& to, double* to_toi, double* to_d0) {
        size_t i = 0;
        for (size_t j = 0; j < to.size(); ++j) {
          while (i < from.size() && from[i] < to[j]) ++i;
          if (i < from.size() && SamePair(from[i], to[j])) {
            to_toi[j] = from_toi[i];
            to_d0[j] = from_d0[i];
          }
        }
      };
      const size_t cvf = cand.vf.size(), nvf = next.vf.size();
      carry(cand.vf, cand_toi.data(), cand_d0.data(), next.vf, next_toi.data(), next_d0.data());
      carry(cand.ee, cand_toi.data() + cvf, cand_d0.data() + cvf, next.ee, next_toi.data() + nvf, next_d0.data() + nvf);
    }
    cand_toi.swap(next_toi);
    cand_d0.swap(next_d0);
  }

  Stencil VF(int v, int f) const { return {{v, F(f, 0), F(f, 1), F(f, 2)}, true}; }
  Stencil EE(int a, int b) const { return {{E[a][0], E[a][1], E[b][0], E[b][1]}, false}; }

  // Pairs that could come within min_separation on the paths x0 → x1: all the CCD
  // needs, found again whenever a node moved since the last query (mostly by filtering
  // repulsion's pairs, below). Boxes with room for later corrections (0.25 × thickness
  // until 2026-12-07) saved queries but gave the CCD ~1.8× the pairs to test, which cost
  // more (docs/simulation.md). *t0: the caller's clock reading; a search is timed from
  // it as broad phase and *t0 moved to its end (the check alone stays the caller's: one
  // clock reading fewer per call).
  const CandidatePairs& Fresh(double* t0) {
    if (!have_cand || x1 != box_ref) {
      // The repulsion's pairs hold every pair whose boxes overlap inside its boxes: when
      // these boxes lie inside them (x1 moved little since), filtering them is FindClose.
      PathBoxes(x0, x1, opt.min_separation, 0, &fresh_boxes);
      if (shortcuts && !near_boxes.empty() && BoxesInside(fresh_boxes, near_boxes))
        broad.Filter(fresh_boxes, near, &next);
      else
        broad.FindClosePaths(fresh_boxes, x0, &next);
      ++rep.broad_builds;
      rep.broad_candidates += static_cast<long long>(next.vf.size() + next.ee.size());
      box_ref = x1;
      CarryResults();
      std::swap(cand, next);
      have_cand = true;
      const double t1 = ClockSeconds();
      rep.broad_seconds += t1 - *t0;
      *t0 = t1;
    }
    return cand;
  }
};

// ---- strain limiting ------------------------------------------------------------
// Hop distance of every node from the nodes with w == 0 (INT_MAX: none reachable).
std::vector<int> HopLevels(const std::vector<int>& start, const std::vector<int>& adj, const Eigen::VectorXd& w) {
  const int n = static_cast<int>(w.size());
  std::vector<int> level(n, std::numeric_limits<int>::max()), queue;
  for (int i = 0; i < n; ++i)
    if (w[i] == 0) {
      level[i] = 0;
      queue.push_back(i);
    }
  for (size_t q = 0; q < queue.size(); ++q) {
    const int v = queue[q];
    for (int k = start[v]; k < start[v + 1]; ++k)
      if (level[adj[k]] == std::numeric_limits<int>::max()) {
        level[adj[k]] = level[v] + 1;
        queue.push_back(adj[k]);
      }
  }
  return level;
}

// Edge length bounds as multiples of L0: [lo, hi] clamped to, [lo_ok, hi_ok] accepted.
struct StrainBounds {
  double lo, hi, lo_ok, hi_ok;
  bool active;
  explicit StrainBounds(const CollisionOptions& o)
      : lo(o.max_compression > 0 ? 1 - o.max_compression : 0),
        hi(o.max_strain > 0 ? 1 + o.max_strain : std::numeric_limits<double>::infinity()),
        lo_ok(o.max_compression > 0 ? lo - o.strain_tolerance : 0),
        hi_ok(hi + o.strain_tolerance),
        active(std::isfinite(hi) || lo > 0) {}
};

// The clamp's sweeps as written (SetShortcuts(false): the reference for ClampSweeps).
void ClampSweepsReference(ApplyContext& cx, const Eigen::VectorXd& w, const StrainBounds& b) {
  const CollisionHandler::StrainOrder& so = cx.strain_order;
  const std::vector<int>& level = so.level;
  const std::vector<int>& order = so.order;
  for (int it = 0; it < cx.opt.strain_iterations; ++it) {
    double worst = 0;  // largest relative violation corrected in this sweep
    for (const int e : order) {
      const int i = cx.E[e][0], j = cx.E[e][1];
      double wi = w[i], wj = w[j];
      if (level[i] < level[j]) wi *= cx.opt.strain_lead_weight;
      if (level[j] < level[i]) wj *= cx.opt.strain_lead_weight;
      const double L0 = cx.rest_lengths[e];
      if (!(L0 > 0) || !(wi + wj > 0)) continue;
      const Vec3 d = (cx.x1.row(j) - cx.x1.row(i)).transpose();
      const double l = d.norm();
      double target = l;
      if (l > b.hi * L0)
        target = b.hi * L0;
      else if (l < b.lo * L0 && l > 0)
        target = b.lo * L0;
      else
        continue;
      worst = std::max(worst, std::abs(l - target) / L0);
      const Vec3 corr = d * ((l - target) / l);
      cx.x1.row(i) += (wi / (wi + wj)) * corr.transpose();
      cx.x1.row(j) -= (wj / (wi + wj)) * corr.transpose();
      ++cx.rep.strain_corrections;
    }
    if (worst < 1e-6) break;
  }
}

// so.edges for w: the same products and quotients the reference computes per visit.
void PrepareClampEdges(ApplyContext& cx, const Eigen::VectorXd& w, const StrainBounds& b) {
  CollisionHandler::StrainOrder& so = cx.strain_order;
  if (so.edges_valid && so.w.size() == w.size() &&
      std::memcmp(so.w.data(), w.data(), sizeof(double) * static_cast<size_t>(w.size())) == 0)
    return;
  so.edges.clear();
  for (const int e : so.order) {
    const int i = cx.E[e][0], j = cx.E[e][1];
    double wi = w[i], wj = w[j];
    if (so.level[i] < so.level[j]) wi *= cx.opt.strain_lead_weight;
    if (so.level[j] < so.level[i]) wj *= cx.opt.strain_lead_weight;
    const double L0 = cx.rest_lengths[e];
    if (!(L0 > 0) || !(wi + wj > 0)) continue;
    const double hi_l = b.hi * L0, lo_l = b.lo * L0;
    so.edges.push_back({i, j, L0, hi_l, lo_l, hi_l * hi_l * kSquaredBelow, lo_l * lo_l * kSquaredAbove, wi / (wi + wj),
                        wj / (wi + wj)});
  }
  so.w = w;
  so.edges_valid = true;
}

// The reference's sweeps on so.edges, with two savings that change no result: an edge
// found within the bounds stays so until a node of it is corrected, so it is not
// measured again until then (stamp: tick of a node's last correction; checked: tick at
// which the edge was last found within, −1: not yet); and an edge surely within the
// bounds from its squared length (bounds squared, pulled in by a relative 1e-12, far
// beyond the few ulps of rounding either side) is not measured by the root (its
// latency held up every edge measured).
void ClampSweeps(ApplyContext& cx, const Eigen::VectorXd& w, const StrainBounds& b) {
  PrepareClampEdges(cx, w, b);
  CollisionHandler::StrainOrder& so = cx.strain_order;
  const std::vector<CollisionHandler::StrainOrder::Edge>& edges = so.edges;
  const int ne = static_cast<int>(edges.size());
  int tick = 0;
  std::vector<int>& stamp = so.stamp;
  std::vector<int>& checked = so.checked;
  stamp.assign(w.size(), 0);
  checked.assign(ne, -1);
  Points3& x1 = cx.x1;
  for (int it = 0; it < cx.opt.strain_iterations; ++it) {
    double worst = 0;  // largest relative violation corrected in this sweep
    for (int p = 0; p < ne; ++p) {
      const CollisionHandler::StrainOrder::Edge& r = edges[p];
      const int i = r.i, j = r.j;
      if (checked[p] >= 0 && stamp[i] <= checked[p] && stamp[j] <= checked[p]) continue;
      const Vec3 d = (x1.row(j) - x1.row(i)).transpose();
      const double l2 = d.squaredNorm();
      if (l2 < r.hi2 && l2 > r.lo2) {
        checked[p] = tick;
        continue;
      }
      const double l = std::sqrt(l2);
      double target = l;
      if (l > r.hi)
        target = r.hi;
      else if (l < r.lo && l > 0)
        target = r.lo;
      else {
        checked[p] = tick;
        continue;
      }
      worst = std::max(worst, std::abs(l - target) / r.L0);
      const Vec3 corr = d * ((l - target) / l);
      x1.row(i) += r.fi * corr.transpose();
      x1.row(j) -= r.fj * corr.transpose();
      stamp[i] = stamp[j] = ++tick;
      ++cx.rep.strain_corrections;
    }
    if (worst < 1e-6) break;
  }
}

// Gauss–Seidel clamp of the edges of x1 into [lo, hi]·L0, sweeping outwards from the
// nodes with w == 0 (kinematic, or frozen in an impact zone): w is the inverse mass
// the clamp uses.
void LimitStrain(ApplyContext& cx, const Eigen::VectorXd& w) {
  const auto t0 = ClockSeconds();
  const StrainBounds b(cx.opt);
  if (!b.active) return;
  CollisionHandler::StrainOrder& so = cx.strain_order;
  std::vector<int> fixed;
  for (int i = 0; i < static_cast<int>(w.size()); ++i)
    if (w[i] == 0) fixed.push_back(i);
  if (!so.valid || fixed != so.fixed) {
    so.fixed = std::move(fixed);
    so.level = HopLevels(cx.adj_start, cx.adj, w);
    // Edges ordered by their hop level (stable: by index within a level).
    const int ne = static_cast<int>(cx.E.size());
    so.order.resize(ne);
    std::iota(so.order.begin(), so.order.end(), 0);
    auto edge_level = [&](int e) { return std::min(so.level[cx.E[e][0]], so.level[cx.E[e][1]]); };
    std::stable_sort(so.order.begin(), so.order.end(), [&](int a, int c) { return edge_level(a) < edge_level(c); });
    so.valid = true;
    so.edges_valid = false;
  }
  if (cx.shortcuts)
    ClampSweeps(cx, w, b);
  else
    ClampSweepsReference(cx, w, b);
  cx.rep.strain_seconds += ClockSince(t0);
}

// Edges of x1 outside the accepted bounds (sorted); *max_strain: the largest (l − L0)/L0.
std::vector<int> StrainViolations(const ApplyContext& cx, double* max_strain = nullptr) {
  const double t0 = ClockSeconds();
  const StrainBounds b(cx.opt);
  std::vector<int> out;
  double worst = -std::numeric_limits<double>::infinity();
  for (int e = 0; e < static_cast<int>(cx.E.size()); ++e) {
    const double L0 = cx.rest_lengths[e];
    if (!(L0 > 0)) continue;
    const double r = (cx.x1.row(cx.E[e][1]) - cx.x1.row(cx.E[e][0])).norm() / L0;
    worst = std::max(worst, r - 1);
    if (r > b.hi_ok || r < b.lo_ok) out.push_back(e);
  }
  if (max_strain) *max_strain = cx.E.empty() ? 0 : worst;
  cx.rep.strain_seconds += ClockSince(t0);
  return out;
}

// Edges of x1 outside the accepted bounds that were within them at x0, or were outside
// them already and are further outside by more than strain_tolerance (longer above the
// upper bound, shorter below the lower one), sorted: what the step made worse. The
// tolerance leaves alone the edges next to a grip that the clamp leaves a sliver beyond
// the bound step after step (they merged in most steps of a hang without it, as with
// strain_zones); it never lets an edge that started within the bound leave it (it did:
// in a hand-over fall an edge went from strain 0.04087 to 0.04101, bound 0.041, and on
// by a few 1e-6 per step).
std::vector<int> StrainWorsened(const ApplyContext& cx) {
  const double t0 = ClockSeconds();
  const StrainBounds b(cx.opt);
  std::vector<int> out;
  for (int e = 0; e < static_cast<int>(cx.E.size()); ++e) {
    const double L0 = cx.rest_lengths[e];
    if (!(L0 > 0)) continue;
    const int i = cx.E[e][0], j = cx.E[e][1];
    const double r1 = (cx.x1.row(j) - cx.x1.row(i)).norm() / L0;
    if (r1 <= b.hi_ok && r1 >= b.lo_ok) continue;
    const double r0 = (cx.x0.row(j) - cx.x0.row(i)).norm() / L0;
    const double tol = cx.opt.strain_tolerance;
    if ((r1 > b.hi_ok && (r0 <= b.hi_ok || r1 > r0 + tol)) || (r1 < b.lo_ok && (r0 >= b.lo_ok || r1 < r0 - tol)))
      out.push_back(e);
  }
  cx.rep.strain_seconds += ClockSince(t0);
  return out;
}

// The stretched edges the fail-safe merges into zones: all (strain_zones), those the
// step made worse (strain_monotone) or none.
std::vector<int> EdgesToMerge(const ApplyContext& cx, const std::vector<int>& stretched) {
  if (stretched.empty()) return {};
  if (cx.opt.strain_zones) return stretched;
  if (cx.opt.strain_monotone) return StrainWorsened(cx);
  return {};
}

// ---- proximity repulsion (Bridson §7.2) -------------------------------------------
// Whether the pair is surely at least `reach` apart at x0 and at x1, from its distance
// d_snap at the snapshot xs: each node i has moved by at most
// max(|x0_i − xs_i|, |x1_i − xs_i|) since (moves: the square of that per node, kept
// up to date with x1 by Repel), and a distance changes by at most twice the largest
// move of the pair's nodes (the closest points of the snapshot, carried by the same
// weights, move no further than that).
bool FarSinceSnapshot(const Stencil& s, double d_snap, const std::vector<double>& moves, double reach) {
  if (!(d_snap > reach)) return false;  // also NaN: no snapshot distance
  const double m2 = std::max({moves[s.n[0]], moves[s.n[1]], moves[s.n[2]], moves[s.n[3]]});
  return d_snap - 2 * std::sqrt(m2) >= reach;
}

// d_snap: the pair's distance at the repulsion snapshot (NaN: none); *d0_out (if given)
// gets its distance at x0. False when the pair is left alone (far, or touching at x0),
// true when it was pushed apart.
// x1 changes only when it returns true.
bool RepelPair(ApplyContext& cx, const Stencil& s, double d_snap, const std::vector<double>& moves, double* d0_out) {
  double h = cx.opt.thickness;
  const double reach = h + kRepelSkipMargin;  // a pair surely this far is left alone as min(d0, d1) >= h below
  if (FarSinceSnapshot(s, d_snap, moves, reach)) return false;
  const Quad q0 = Gather(s, cx.x0), q1 = Gather(s, cx.x1);
  // Most candidates are far at both ends (95 % on the paper's garments), and the bound
  // shows it for ~4 in 5 of them without the closest points.
  const bool far1 = cx.shortcuts && SurelyFarther(s.vf, q1, reach);
  if (far1 && !d0_out && SurelyFarther(s.vf, q0, reach)) return false;
  ++cx.rep.proximity_tests;
  Coeffs c0, c1;
  const double d0 = std::sqrt(Closest(s.vf, q0, &c0));
  if (d0_out) *d0_out = d0;
  if (far1 && d0 >= h) return false;
  const double d1 = std::sqrt(Closest(s.vf, q1, &c1));
  if (std::min(d0, d1) >= h || !(d0 > 0)) return false;  // far, or touching at x0 (the CCD's job)
  // Pairs closer than thickness in the flat garment (seams, small triangles) keep their rest distance.
  h = std::min(h, std::sqrt(Closest(s.vf, Gather(s, cx.rest), nullptr)));
  if (std::min(d0, d1) >= h) return false;
  const Vec3 u0 = Combine(c0, q0) / d0;  // x0 is intersection-free: its side is the right one
  Coeffs c;
  Vec3 n;
  double target;
  if (d0 < h) {
    c = c0;
    n = u0;
    target = d0 + cx.opt.repulsion_fraction * (h - d0);
  } else {  // far at x0, close at x1: stop at the thickness, on x0's side
    c = c1;
    n = d1 > 0 ? Vec3(Combine(c1, q1) / d1) : u0;
    if (n.dot(u0) < 0) n = -n;
    target = h;
  }
  const double sep = Combine(c, q1).dot(n);
  if (sep >= target) return false;
  if (!ShiftRelative(s, c, (target - sep) * n, cx.inv_mass, cx.x1)) return false;
  PairFriction(s, c, n, target - sep, cx.opt.cloth_friction, cx.x0, cx.friction_from, cx.inv_mass, cx.x1);
  return true;
}

// The snapshot distance of every pair of `to` that is in `from` (both sorted), NaN for
// the others.
void SnapshotDistances(const std::vector<std::array<int, 2>>& from, const double* from_d,
                       const std::vector<std::array<int, 2>>& to, double* to_d) {
  size_t i = 0;
  for (size_t j = 0; j < to.size(); ++j) {
    while (i < from.size() && from[i] < to[j]) ++i;
    to_d[j] = i < from.size() && SamePair(from[i], to[j]) ? from_d[i] : std::numeric_limits<double>::quiet_NaN();
  }
}

// Gauss–Seidel sweeps; a sweep after the first visits only the pairs with a node moved
// in the sweep before (any other pair sees what it saw then and does nothing again).
// Every kRepelSnapshotCalls-th call keeps x0 and the pairs' distances there (the first
// sweep measures every pair at x0); the calls between skip the pairs that are surely
// still beyond the thickness (FarSinceSnapshot): about half of them in a settling hang.
void Repel(ApplyContext& cx) {
  auto t0 = ClockSeconds();
  PathBoxes(cx.x0, cx.x1, cx.opt.thickness, 0, &cx.near_boxes);
  cx.broad.FindClosePaths(cx.near_boxes, cx.x0, &cx.near);
  ++cx.rep.broad_builds;
  cx.rep.broad_candidates += static_cast<long long>(cx.near.vf.size() + cx.near.ee.size());
  const double t1 = ClockSeconds();
  cx.rep.broad_seconds += t1 - t0;
  t0 = t1;
  const CandidatePairs& cand = cx.near;
  const int n = static_cast<int>(cx.x1.rows());
  CollisionHandler::RepelSnapshot& snap = cx.repel_snapshot;
  const bool take = snap.calls++ % kRepelSnapshotCalls == 0 || snap.x.rows() != n || !cx.shortcuts;
  const size_t nvf = cand.vf.size();
  std::vector<double> d_snap(nvf + cand.ee.size(), std::numeric_limits<double>::quiet_NaN());
  // Per node: |x0_i − xs_i|² (move0) and max(that, |x1_i − xs_i|²) (moves, updated for
  // the nodes of every pair that moves x1).
  std::vector<double> move0(n, 0.0), moves(n, 0.0);
  auto update_move = [&](int i) { moves[i] = std::max(move0[i], (cx.x1.row(i) - snap.x.row(i)).squaredNorm()); };
  if (!take) {
    SnapshotDistances(snap.vf, snap.d.data(), cand.vf, d_snap.data());
    SnapshotDistances(snap.ee, snap.d.data() + snap.vf.size(), cand.ee, d_snap.data() + nvf);
    for (int i = 0; i < n; ++i) {
      move0[i] = (cx.x0.row(i) - snap.x.row(i)).squaredNorm();
      update_move(i);
    }
  } else {
    snap.x = cx.x0;
    snap.vf = cand.vf;
    snap.ee = cand.ee;
    snap.d.assign(d_snap.size(), std::numeric_limits<double>::quiet_NaN());
  }
  std::vector<char> moved_node(n, 1);
  Points3 before;
  for (int it = 0; it < cx.opt.proximity_iterations; ++it) {
    before = cx.x1;
    int moved = 0;
    size_t k = 0;
    auto visit = [&](const Stencil& s) {
      const size_t pair = k++;  // the first sweep visits every pair; at a snapshot none is skipped
      if (!(moved_node[s.n[0]] || moved_node[s.n[1]] || moved_node[s.n[2]] || moved_node[s.n[3]])) return;
      if (!RepelPair(cx, s, d_snap[pair], moves, take && it == 0 ? &snap.d[pair] : nullptr)) return;
      ++moved;
      if (!take)
        for (const int i : s.n) update_move(i);
    };
    for (const auto& [v, f] : cand.vf) visit(cx.VF(v, f));
    for (const auto& [a, b] : cand.ee) visit(cx.EE(a, b));
    cx.rep.proximity_pairs += moved;
    if (moved == 0) break;
    for (int i = 0; i < n; ++i) moved_node[i] = cx.x1.row(i) != before.row(i);
  }
  cx.rep.proximity_seconds += ClockSince(t0);
}

// ---- static boxes --------------------------------------------------------------------
// Puts a node whose path enters the box (grown by pad) back on the face it entered
// through, with Coulomb friction on its tangential displacement. True if it moved.
// Slab test of the segment p0 → p1 (box frame) against the open box |p| < h: true when
// the segment enters it; *axis: the face's axis it enters through (−1: p0 is inside).
bool SegmentEntersBox(const Vec3& p0, const Vec3& p1, const Vec3& h, int* axis) {
  const Vec3 d = p1 - p0;
  double enter = 0, exit = 1;
  *axis = -1;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (std::abs(p0[a]) >= h[a]) return false;
      continue;
    }
    double t1 = (-h[a] - p0[a]) / d[a], t2 = (h[a] - p0[a]) / d[a];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > enter) enter = t1, *axis = a;
    exit = std::min(exit, t2);
  }
  return enter < exit;
}

bool CollideNode(const BoxCollider& box, double pad, const Vec3& x0, Vec3& x1) {
  const Eigen::Isometry3d inv = box.pose.inverse(Eigen::Isometry);
  const Vec3 p0 = inv * x0, h = box.half_extents.array() + pad;
  Vec3 p1 = inv * x1;
  int axis = -1;
  if (!SegmentEntersBox(p0, p1, h, &axis)) return false;
  double side;
  if (axis >= 0) {
    side = p0[axis] > 0 ? 1 : -1;
  } else {  // x0 on or inside the surface (resting contact): its nearest face
    (h - p0.cwiseAbs()).minCoeff(&axis);
    side = p0[axis] >= 0 ? 1 : -1;
  }
  const double depth = std::abs(side * h[axis] - p1[axis]);
  p1[axis] = side * h[axis];
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const Eigen::Vector2d slide(p1[u] - p0[u], p1[v] - p0[v]);
  const double len = slide.norm(), stop = box.friction * depth;
  const Eigen::Vector2d kept = len <= stop ? Eigen::Vector2d::Zero() : Eigen::Vector2d(slide * (1 - stop / len));
  p1[u] = p0[u] + kept[0];
  p1[v] = p0[v] + kept[1];
  x1 = box.pose * p1;
  return true;
}

// frozen (optional): nodes in an impact zone, left alone.
void HandleColliders(ApplyContext& cx, const std::vector<BoxCollider>& colliders,
                     const std::vector<char>* frozen = nullptr) {
  if (colliders.empty()) return;
  const auto t0 = ClockSeconds();
  for (int i = 0; i < cx.x1.rows(); ++i) {
    if (cx.inv_mass[i] == 0 || (frozen && (*frozen)[i])) continue;
    const Vec3 a = cx.x0.row(i).transpose();
    Vec3 b = cx.x1.row(i).transpose();
    bool hit = false;
    for (const BoxCollider& box : colliders) hit |= CollideNode(box, 0.5 * cx.opt.thickness, a, b);
    if (hit) {
      cx.x1.row(i) = b.transpose();
      ++cx.rep.collider_contacts;
    }
  }
  cx.rep.collider_seconds += ClockSince(t0);
}

// ---- box edges and corners ------------------------------------------------------------------
// Nodes are kept out of the boxes above; a cloth edge can still cut across a box's edge
// and a box's corner poke through a cloth face with every node outside. These pairs
// (cloth EE against the box's 12 edges, cloth faces against its 8 corners) go through the
// same CCD with the box as infinitely heavy and static, and so does every node path
// (against the box itself, no pad) after the last change of x1.
struct BoxHit {
  bool vf = false;         // corner–face (slot 0: the corner) or edge–edge (slots 2, 3: the box's)
  std::array<int, 4> n{};  // node per cloth slot (−1: a box point)
  Quad box{Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};  // the box points in their slots
  double toi = 0;
  int node_box = -1;  // ≥ 0: the path of node n[0] enters this box (no CCD pair)
};

Quad BoxGather(const BoxHit& h, const Points3& x) {
  Quad q = h.box;
  for (int k = 0; k < 4; ++k)
    if (h.n[k] >= 0) q[k] = x.row(h.n[k]).transpose();
  return q;
}

struct BoxGeometry {
  std::array<Vec3, 8> corner;
  Aabb bounds;
};
constexpr std::array<std::array<int, 2>, 12> kBoxEdges = {
    {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3}, {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}}};
BoxGeometry Geometry(const BoxCollider& b) {
  BoxGeometry g;
  for (int k = 0; k < 8; ++k) {
    const Vec3 s((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, (k & 4) ? 1 : -1);
    g.corner[k] = b.pose * Vec3(s.cwiseProduct(b.half_extents));
  }
  g.bounds = {g.corner[0], g.corner[0]};
  for (const Vec3& c : g.corner) g.bounds = {g.bounds.lo.cwiseMin(c), g.bounds.hi.cwiseMax(c)};
  return g;
}

// Colliding box pairs on x0 → x1; nodes with static[i] set (frozen at x0 in a pinned zone) are skipped.
std::vector<BoxHit> DetectBoxes(ApplyContext& cx, const std::vector<BoxCollider>& colliders,
                                const std::vector<char>* pinned = nullptr) {
  std::vector<BoxHit> hits;
  if (colliders.empty()) return hits;
  const auto t0 = ClockSeconds();
  const double pad = cx.opt.min_separation;
  auto moving = [&](int i) { return cx.inv_mass[i] != 0 && !(pinned && (*pinned)[i]); };
  auto node_box = [&](int i) {
    const Vec3 a = cx.x0.row(i).transpose(), b = cx.x1.row(i).transpose();
    return Aabb{a.cwiseMin(b).array() - pad, a.cwiseMax(b).array() + pad};
  };
  for (int b = 0; b < static_cast<int>(colliders.size()); ++b) {
    const BoxGeometry g = Geometry(colliders[b]);
    const Eigen::Isometry3d inv = colliders[b].pose.inverse(Eigen::Isometry);
    for (int i = 0; i < cx.x1.rows(); ++i) {  // node paths against the box itself
      if (!moving(i) || !node_box(i).Overlaps(g.bounds)) continue;
      const Vec3 p0 = inv * Vec3(cx.x0.row(i).transpose()), p1 = inv * Vec3(cx.x1.row(i).transpose());
      int axis = -1;
      if (SegmentEntersBox(p0, p1, colliders[b].half_extents, &axis) && axis >= 0) {
        BoxHit h;
        h.n = {i, -1, -1, -1};
        h.node_box = b;
        hits.push_back(h);
      }
    }
    for (int e = 0; e < static_cast<int>(cx.E.size()); ++e) {  // cloth edges against box edges
      const auto [i, j] = cx.E[e];
      if (!moving(i) && !moving(j)) continue;
      const Aabb eb{node_box(i).lo.cwiseMin(node_box(j).lo), node_box(i).hi.cwiseMax(node_box(j).hi)};
      if (!eb.Overlaps(g.bounds)) continue;
      for (const auto& [a, c] : kBoxEdges) {
        const Aabb be{g.corner[a].cwiseMin(g.corner[c]), g.corner[a].cwiseMax(g.corner[c])};
        if (!eb.Overlaps(be)) continue;
        BoxHit h;
        h.n = {i, j, -1, -1};
        h.box = {Vec3::Zero(), Vec3::Zero(), g.corner[a], g.corner[c]};
        if (AdditiveCCD(false, BoxGather(h, cx.x0), BoxGather(h, cx.x1), cx.opt.min_separation, &h.toi))
          hits.push_back(h);
      }
    }
    for (int f = 0; f < cx.F.rows(); ++f) {  // box corners against cloth faces
      const int fa = cx.F(f, 0), fb = cx.F(f, 1), fc = cx.F(f, 2);
      if (!moving(fa) && !moving(fb) && !moving(fc)) continue;
      Aabb fbx = node_box(fa);
      for (int v : {fb, fc}) fbx = {fbx.lo.cwiseMin(node_box(v).lo), fbx.hi.cwiseMax(node_box(v).hi)};
      if (!fbx.Overlaps(g.bounds)) continue;
      for (const Vec3& corner : g.corner) {
        if (!fbx.Overlaps(Aabb{corner, corner})) continue;
        BoxHit h;
        h.vf = true;
        h.n = {-1, fa, fb, fc};
        h.box = {corner, Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
        if (AdditiveCCD(true, BoxGather(h, cx.x0), BoxGather(h, cx.x1), cx.opt.min_separation, &h.toi))
          hits.push_back(h);
      }
    }
  }
  cx.rep.collider_seconds += ClockSince(t0);
  return hits;
}

// Removes the cloth's approaching normal motion against the static box feature at the
// time of impact (a node entering the box: put back on its surface).
void BoxImpulse(ApplyContext& cx, const BoxHit& hit, const std::vector<BoxCollider>& colliders) {
  if (hit.node_box >= 0) {
    const int i = hit.n[0];
    Vec3 b = cx.x1.row(i).transpose();
    if (CollideNode(colliders[hit.node_box], 0.5 * cx.opt.thickness, cx.x0.row(i).transpose(), b))
      cx.x1.row(i) = b.transpose();
    return;
  }
  const Quad q0 = BoxGather(hit, cx.x0), q1 = BoxGather(hit, cx.x1), qt = Lerp(q0, q1, hit.toi);
  Coeffs c;
  const double d = std::sqrt(Closest(hit.vf, qt, &c));
  Vec3 n = d > 0 ? Combine(c, qt) : Combine(c, q0);
  if (!(n.norm() > 0)) return;
  n.normalize();
  const double vn = (Combine(c, q1) - Combine(c, q0)).dot(n);
  if (vn >= 0) return;
  double denom = 0;
  for (int k = 0; k < 4; ++k)
    if (hit.n[k] >= 0) denom += c[k] * c[k] * cx.inv_mass[hit.n[k]];
  if (!(denom > 0)) return;
  for (int k = 0; k < 4; ++k)
    if (hit.n[k] >= 0) cx.x1.row(hit.n[k]) += (c[k] * cx.inv_mass[hit.n[k]] / denom * -vn) * n.transpose();
}

// ---- continuous collision detection and impulses (Bridson §7.3) -------------------------
// Colliding pairs on x0 → x1; pairs whose nodes all lie in one rigid zone are skipped.
std::vector<Hit> Detect(ApplyContext& cx, const std::vector<int>* zone_of) {
  auto t0 = ClockSeconds();
  const CandidatePairs& cand = cx.Fresh(&t0);
  const int n = static_cast<int>(cx.x1.rows());
  const bool have_ref = cx.detect_ref.rows() == n && cx.shortcuts;
  cx.dirty.resize(n);
  for (int i = 0; i < n; ++i) cx.dirty[i] = !have_ref || cx.x1.row(i) != cx.detect_ref.row(i);
  cx.detect_ref = cx.x1;
  std::vector<Hit> hits;
  size_t k = 0;  // candidate index: VF pairs, then EE pairs
  auto test = [&](const Stencil& s) {
    double& d0 = cx.cand_d0[k];
    double& cached = cx.cand_toi[k++];
    if (zone_of) {
      const int z = (*zone_of)[s.n[0]];
      if (z >= 0 && (*zone_of)[s.n[1]] == z && (*zone_of)[s.n[2]] == z && (*zone_of)[s.n[3]] == z) {
        cached = std::numeric_limits<double>::quiet_NaN();  // not tested: unknown next time
        return;
      }
    }
    // x0 is fixed for the call: a pair none of whose nodes moved has the same answer.
    if (std::isnan(cached) || cx.dirty[s.n[0]] || cx.dirty[s.n[1]] || cx.dirty[s.n[2]] || cx.dirty[s.n[3]]) {
      double toi = 0;
      ++cx.rep.ccd_tests;
      cached = AdditiveCCD(s.vf, Gather(s, cx.x0), Gather(s, cx.x1), cx.opt.min_separation, &toi,
                           cx.shortcuts ? &d0 : nullptr)
                   ? toi
                   : -1.0;
    }
    if (cached >= 0) hits.push_back({s, cached});
  };
  for (const auto& [v, f] : cand.vf) test(cx.VF(v, f));
  for (const auto& [a, b] : cand.ee) test(cx.EE(a, b));
  cx.rep.ccd_seconds += ClockSince(t0);
  return hits;
}

// Removes the approaching relative normal motion of a pair at its time of impact.
void Impulse(ApplyContext& cx, const Hit& hit) {
  const Quad q0 = Gather(hit.s, cx.x0), q1 = Gather(hit.s, cx.x1);
  const Quad qt = Lerp(q0, q1, hit.toi);
  Coeffs c;
  const double d = std::sqrt(Closest(hit.s.vf, qt, &c));
  Vec3 n = Combine(c, qt);
  if (!(d > 0)) n = Combine(c, q0);  // touching at the impact: the direction at x0
  if (!(n.norm() > 0)) return;
  n.normalize();
  const double vn = (Combine(c, q1) - Combine(c, q0)).dot(n);
  if (vn >= 0) return;
  if (ShiftRelative(hit.s, c, -vn * n, cx.inv_mass, cx.x1))
    PairFriction(hit.s, c, n, -vn, cx.opt.cloth_friction, cx.x0, cx.friction_from, cx.inv_mass, cx.x1);
}

// Pairs still colliding after the impulses: cloth–cloth and cloth–box.
struct Pending {
  std::vector<Hit> self;
  std::vector<BoxHit> box;
  bool Empty() const { return self.empty() && box.empty(); }
};

// ---- rigid impact zones (Provot 1997, Bridson §7.4) ----------------------------------
// Moves the zone's free nodes rigidly; returns false when its kinematic nodes moved non-rigidly.
bool MoveZone(ApplyContext& cx, const std::vector<int>& zone, const Points3& xin) {
  std::vector<int> held;
  for (int i : zone)
    if (cx.inv_mass[i] == 0) held.push_back(i);
  const Rigid r = held.empty() ? MomentumRigid(zone, cx.x0, xin, cx.inv_mass) : KinematicRigid(held, cx.x0, cx.x1);
  bool rigid = true;
  for (int i : held)
    rigid &= (r.c1 + r.R * (cx.x0.row(i).transpose() - r.c0) - cx.x1.row(i).transpose()).norm() <= kRigidTolerance;
  for (int i : zone)
    if (cx.inv_mass[i] != 0) cx.x1.row(i) = (r.c1 + r.R * (cx.x0.row(i).transpose() - r.c0)).transpose();
  return rigid;
}

// Zones as node lists (ordered by smallest node) and the node → zone map.
std::vector<std::vector<int>> BuildZones(UnionFind& uf, const std::vector<char>& in_zone, std::vector<int>* zone_of) {
  std::vector<std::vector<int>> zones;
  std::vector<int> of_root(in_zone.size(), -1);
  zone_of->assign(in_zone.size(), -1);
  for (int i = 0; i < static_cast<int>(in_zone.size()); ++i) {
    if (!in_zone[i]) continue;
    const int root = uf.Find(i);
    if (of_root[root] < 0) {
      of_root[root] = static_cast<int>(zones.size());
      zones.emplace_back();
    }
    zones[of_root[root]].push_back(i);
    (*zone_of)[i] = of_root[root];
  }
  return zones;
}

// Edges in `stretched` whose two nodes are not in one zone (a zone keeps x0's lengths:
// merging cannot change an edge inside it).
std::vector<int> AcrossZones(const ApplyContext& cx, const std::vector<int>& stretched,
                             const std::vector<int>& zone_of) {
  std::vector<int> out;
  for (int e : stretched) {
    const int z = zone_of[cx.E[e][0]];
    if (z < 0 || zone_of[cx.E[e][1]] != z) out.push_back(e);
  }
  return out;
}

// A zone touching a box stays where it was at x0 (the identity is rigid, and x0 was
// clear of the static box); false when its kinematic nodes move (then it cannot).
bool FreezeZone(ApplyContext& cx, const std::vector<int>& zone) {
  bool still = true;
  for (int i : zone) {
    if (cx.inv_mass[i] != 0)
      cx.x1.row(i) = cx.x0.row(i);
    else
      still &= cx.x1.row(i) == cx.x0.row(i);
  }
  return still;
}

// One round's merges into the zones: nodes of colliding pairs, of pairs against a box
// (pinned: such a zone stays at x0) and of edges beyond the strain bound. `level`: hop
// levels from the kinematic nodes, computed on first need.
void MergeRound(ApplyContext& cx, const Pending& pending, const std::vector<int>& stretched, UnionFind& uf,
                std::vector<char>& in_zone, std::vector<char>& pinned, std::vector<int>& level) {
  for (const Hit& h : pending.self)
    for (int k = 0; k < 4; ++k) {
      in_zone[h.s.n[k]] = 1;
      uf.Unite(h.s.n[0], h.s.n[k]);
    }
  for (const BoxHit& h : pending.box) {
    int first = -1;
    for (int i : h.n) {
      if (i < 0) continue;
      in_zone[i] = pinned[i] = 1;
      if (first < 0) first = i;
      uf.Unite(first, i);
    }
  }
  // A stretched edge of two free nodes, neither in a zone, first freezes only its lead
  // node (the one nearer the kinematic nodes; a zone of its own, which stays where the
  // step left it), so that the clamp below shortens the edge by moving the other node
  // alone. Merging both nodes keeps the edge's x0 length, which cannot help an edge
  // already beyond the bound at x0: that is what an edge still stretched next round
  // (or next to a zone, or a kinematic node) gets.
  if (!stretched.empty() && level.empty()) level = HopLevels(cx.adj_start, cx.adj, cx.inv_mass);
  const std::vector<char> was_in_zone = in_zone;
  for (int e : stretched) {
    const int a = cx.E[e][0], b = cx.E[e][1];
    if (!was_in_zone[a] && !was_in_zone[b] && cx.inv_mass[a] != 0 && cx.inv_mass[b] != 0) {
      in_zone[level[b] < level[a] ? b : a] = 1;
      continue;
    }
    in_zone[a] = in_zone[b] = 1;
    uf.Unite(a, b);
    ++cx.rep.strain_merges;
  }
}

// The phases the fail-safe calls (its own time is what it spends beyond them).
double PhaseSeconds(const CollisionReport& r) {
  return r.ccd_seconds + r.broad_seconds + r.strain_seconds + r.collider_seconds;
}

// Rigid impact zones, merged from colliding pairs, from pairs against a box (such a
// zone is pinned: it stays at x0) and from edges beyond the strain bound; after each
// move the free nodes are clamped with the zones frozen and the colliders re-checked,
// so the last change of x1 is always followed by all the checks.
void ImpactZones(ApplyContext& cx, Pending pending, std::vector<int> stretched,
                 const std::vector<BoxCollider>& colliders) {
  const auto t0 = ClockSeconds();
  const CollisionReport before = cx.rep;
  cx.rep.fail_safe_used = true;
  const int n = static_cast<int>(cx.x1.rows());
  const Points3 xin = cx.x1;  // zone momenta come from the motion proposed here
  UnionFind uf(n);
  std::vector<char> in_zone(n, 0), nonrigid_node(n, 0), pinned(n, 0);
  std::vector<int> zone_of(n, -1);
  std::vector<std::vector<int>> zones;
  Eigen::VectorXd w = cx.inv_mass;          // the clamp's inverse masses: zone nodes frozen
  std::vector<int> level;                   // hop levels from the kinematic nodes (lead node of an edge: the lower)
  if (!pending.Empty()) stretched.clear();  // the clamp after the first zone move may fix them
  while (!pending.Empty() || !stretched.empty()) {
    if (cx.rep.zone_iterations == cx.opt.max_zone_iterations) {  // last resort: one zone
      std::fill(in_zone.begin(), in_zone.end(), 1);
      for (int i = 1; i < n; ++i) uf.Unite(0, i);
      cx.rep.reverted = true;
    }
    ++cx.rep.zone_iterations;
    MergeRound(cx, pending, stretched, uf, in_zone, pinned, level);
    zones = BuildZones(uf, in_zone, &zone_of);
    for (const auto& zone : zones) {
      const bool pin = std::any_of(zone.begin(), zone.end(), [&](int i) { return pinned[i] != 0; });
      if (pin)
        for (int i : zone) pinned[i] = 1;
      if (!(pin ? FreezeZone(cx, zone) : MoveZone(cx, zone, xin))) {
        cx.rep.nonrigid_kinematic = true;
        for (int i : zone) nonrigid_node[i] = 1;
      }
    }
    if (cx.rep.reverted) break;  // one zone: nothing is left to clamp or collide
    for (int i = 0; i < n; ++i) w[i] = in_zone[i] ? 0.0 : cx.inv_mass[i];
    LimitStrain(cx, w);
    HandleColliders(cx, colliders, &in_zone);
    pending = {Detect(cx, &zone_of), DetectBoxes(cx, colliders, &pinned)};
    stretched = AcrossZones(cx, EdgesToMerge(cx, StrainViolations(cx)), zone_of);
  }
  cx.rep.impact_zones = static_cast<int>(zones.size());
  std::vector<Hit> hits;
  if (cx.rep.nonrigid_kinematic) {  // pairs inside a non-rigid zone are not covered: count them
    for (int i = 0; i < n; ++i)
      if (nonrigid_node[i]) zone_of[i] = -1;
    hits = Detect(cx, &zone_of);
  }
  cx.rep.remaining_collisions = static_cast<int>(hits.size());
  cx.rep.collider_violations = static_cast<int>(DetectBoxes(cx, colliders, &pinned).size());
  cx.rep.zone_seconds += ClockSince(t0) - (PhaseSeconds(cx.rep) - PhaseSeconds(before));
}

// CCD + impulse passes until no pair collides (cloth–cloth and cloth–box) or
// ccd_iterations passes ran; returns the pairs still colliding.
Pending ImpulsePasses(ApplyContext& cx, const std::vector<BoxCollider>& colliders) {
  for (int pass = 0;; ++pass) {
    Pending p{Detect(cx, nullptr), DetectBoxes(cx, colliders)};
    if (p.Empty() || pass == cx.opt.ccd_iterations) return p;
    ++cx.rep.ccd_passes;
    cx.rep.ccd_collisions += static_cast<int>(p.self.size());
    cx.rep.box_collisions += static_cast<int>(p.box.size());
    std::stable_sort(p.self.begin(), p.self.end(), [](const Hit& a, const Hit& b) { return a.toi < b.toi; });
    for (const Hit& h : p.self) Impulse(cx, h);
    for (const BoxHit& h : p.box) BoxImpulse(cx, h, colliders);
  }
}

}  // namespace

CollisionHandler::CollisionHandler(const Faces& F, const Points3& rest, const CollisionOptions& options)
    : F_(F), rest_(rest), num_vertices_(static_cast<int>(rest.rows())), options_(options) {
  options_.Validate();
  if (F.rows() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= num_vertices_))
    throw Error("collision: face index out of range for " + std::to_string(num_vertices_) + " vertices");
  if (!rest.allFinite()) throw Error("collision: rest positions must be finite");
  edges_ = MeshEdges(F, rest);
  rest_lengths_.resize(static_cast<Eigen::Index>(edges_.size()));
  for (size_t e = 0; e < edges_.size(); ++e)
    rest_lengths_[Eigen::Index(e)] = (rest.row(edges_[e][0]) - rest.row(edges_[e][1])).norm();
  broad_ = BroadPhase(F_, edges_, rest);
  broad_.SetReuseMargin(kReuseMargin * options_.thickness);
  adjacency_start_.assign(num_vertices_ + 1, 0);
  for (const auto& e : edges_) ++adjacency_start_[e[0] + 1], ++adjacency_start_[e[1] + 1];
  std::partial_sum(adjacency_start_.begin(), adjacency_start_.end(), adjacency_start_.begin());
  adjacency_.resize(adjacency_start_.back());
  std::vector<int> fill(adjacency_start_.begin(), adjacency_start_.end() - 1);
  for (const auto& e : edges_) adjacency_[fill[e[0]]++] = e[1], adjacency_[fill[e[1]]++] = e[0];
}

void CollisionHandler::SetShortcuts(bool on) {
  shortcuts_ = on;
  broad_.SetReuseMargin(on ? kReuseMargin * options_.thickness : 0.0);
}

CollisionReport CollisionHandler::Apply(const Points3& x0, Points3& x1, const Eigen::VectorXd& inv_mass, double dt,
                                        const std::vector<BoxCollider>& colliders, const Points3* friction_from) {
  const int n = num_vertices_;
  if (x0.rows() != n || x1.rows() != n || inv_mass.size() != n)
    throw Error("collision: Apply expects x0, x1 and inv_mass with " + std::to_string(n) + " rows (got " +
                std::to_string(x0.rows()) + ", " + std::to_string(x1.rows()) + ", " + std::to_string(inv_mass.size()) +
                ")");
  if (!(dt > 0 && std::isfinite(dt))) throw Error("collision: dt must be > 0 s");
  if (!inv_mass.allFinite() || (n > 0 && inv_mass.minCoeff() < 0))
    throw Error("collision: inv_mass must be finite and >= 0");
  if (!x0.allFinite()) throw Error("collision: x0 must be finite");
  if (!x1.allFinite()) throw NumericalError("collision: the proposed positions x1 are not finite");
  if (friction_from && (friction_from->rows() != n || !friction_from->allFinite()))
    throw Error("collision: friction_from must have " + std::to_string(n) + " finite rows");
  for (const BoxCollider& box : colliders) box.Validate();

  const double t0 = ClockSeconds();
  CollisionReport rep;
  const long long searches0 = broad_.searches();
  ApplyContext cx{F_,  edges_,   rest_,         options_,         x0,         friction_from,
                  x1,  inv_mass, rest_lengths_, adjacency_start_, adjacency_, dt,
                  rep, broad_,   strain_order_, repel_snapshot_};
  cx.shortcuts = shortcuts_;
  LimitStrain(cx, inv_mass);
  Repel(cx);
  HandleColliders(cx, colliders);
  Pending pending = ImpulsePasses(cx, colliders);
  std::vector<int> stretched = StrainViolations(cx);
  // Impulses and repulsion re-stretch edges next to contacts: clamp again and re-check.
  while (pending.Empty() && !stretched.empty() && rep.strain_rounds < options_.strain_rounds) {
    ++rep.strain_rounds;
    LimitStrain(cx, inv_mass);
    HandleColliders(cx, colliders);
    pending = ImpulsePasses(cx, colliders);
    stretched = StrainViolations(cx);
  }
  std::vector<int> merge = EdgesToMerge(cx, stretched);
  if (!pending.Empty() || !merge.empty()) ImpactZones(cx, std::move(pending), std::move(merge), colliders);
  rep.strain_violations = static_cast<int>(StrainViolations(cx, &rep.max_strain).size());
  rep.broad_searches = static_cast<int>(broad_.searches() - searches0);
  rep.total_seconds = ClockSince(t0);
  return rep;
}

}  // namespace drape
