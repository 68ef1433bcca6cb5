#include "generator/cloth/bending.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <string>

#include "common/error.h"
#include "common/field_error.h"
#include "common/format.h"

namespace drape {

// Why k = C·B·l²/(2·(A₁ + A₂)): bend an equilateral mesh of side s into a cylinder of
// curvature κ about one of its edge directions. A flat triangle inscribed in the
// cylinder takes the normal of the chord between its extreme vertices, so a hinge on an
// edge along the axis turns by θ = κ·h (h = s·√3/2: each face's normal lies h/2 across
// from the edge) and the hinges of the two other directions not at all (their faces
// span the same chord). With A₁ + A₂ = (√3/2)·s², an axial hinge holds
// k·θ² = C·B·κ²·s²·√3/4, and an area holds 2/(√3·s²) axial edges: C·(B/2)·κ² per area,
// the continuum's at C = 1. (bending_test checks it on a lattice for other axis
// directions too.)
namespace {

constexpr double kPi = std::numbers::pi;

Vec3 Row(const Points3& x, int i) { return x.row(i).transpose(); }

double Stiffness(const BendingModel& m, const BendingState& s, int h) {
  double k = m.stiffness[h];
  if (m.plastic() && m.options.weakening > 0) {
    const Hinge& e = m.hinges[h];
    k /= 1 + m.options.weakening * 0.5 * (s.damage[e.face_c] + s.damage[e.face_d]);
  }
  return k;
}

// The 3×3 map from a face's three edge angles (edge k opposite corner k) to its
// curvature tensor (S00, S11, S01) in an orthonormal frame of the rest face:
// S = Σ_k θ_k·|e_k|/(2A)·t_k t_kᵀ, t_k the in-plane unit normal of edge k (Narain et
// al. 2013; ARCSim's edges_to_face up to the sign of θ, which the yield test ignores).
Eigen::Matrix3d EdgesToFace(const Vec3& p0, const Vec3& p1, const Vec3& p2) {
  const Vec3 u = (p1 - p0).normalized();
  const Vec3 n = (p1 - p0).cross(p2 - p0);
  const double area = 0.5 * n.norm();
  const Vec3 v = n.normalized().cross(u);
  const std::array<Vec3, 3> p{p0, p1, p2};
  Eigen::Matrix3d P;
  for (int k = 0; k < 3; ++k) {
    const Vec3 e = p[(k + 2) % 3] - p[(k + 1) % 3];
    const Eigen::Vector2d e2(e.dot(u), e.dot(v));
    const Eigen::Vector2d t = Eigen::Vector2d(-e2.y(), e2.x()).normalized();
    const double w = e2.norm() / (2 * area);
    P.col(k) << w * t.x() * t.x(), w * t.y() * t.y(), w * t.x() * t.y();
  }
  return P;
}

}  // namespace

double WrapAngle(double a) {
  // Every hinge, every sub-step: a difference of two angles in (−π, π] needs at most one
  // turn added or taken, and a ∓ 2π is exact there (Sterbenz), so these are the values
  // std::remainder gives, without its cost (1.5 % of a build's CPU).
  if (a > -kPi && a <= kPi) return a;
  if (a > kPi && a < 2 * kPi) return a - 2 * kPi;
  if (a <= -kPi && a > -2 * kPi) return a + 2 * kPi;
  a = std::remainder(a, 2 * kPi);  // [−π, π]
  return a <= -kPi ? a + 2 * kPi : a;
}

bool DihedralAngleGradient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, double* theta,
                           std::array<Vec3, 4>* g) {
  const Vec3 e = b - a;
  const double l2 = e.squaredNorm();
  const Vec3 na = e.cross(c - a), nb = (d - a).cross(e);  // |n| = 2·area = l·h
  const double la = na.norm(), lb = nb.norm();
  if (theta) *theta = 0;
  if (g) g->fill(Vec3::Zero());
  if (!(l2 > 0) || !(la > 1e-12 * l2) || !(lb > 1e-12 * l2)) return false;
  const double l = std::sqrt(l2);
  const Vec3 ua = na / la, ub = nb / lb;
  if (theta) *theta = std::atan2(ua.cross(ub).dot(e) / l, ua.dot(ub));
  if (g) {
    // ∂θ/∂c = −n_a/h_a, ∂θ/∂d = −n_b/h_b (h: heights over the edge, h = |n|/l); a and b
    // take the rest by where c and d project onto the edge (Bridson et al. 2003).
    const Vec3 gc = -ua * (l / la), gd = -ub * (l / lb);
    const double tc = (c - a).dot(e) / l2, td = (d - a).dot(e) / l2;
    (*g)[0] = -(1 - tc) * gc - (1 - td) * gd;
    (*g)[1] = -tc * gc - td * gd;
    (*g)[2] = gc;
    (*g)[3] = gd;
  }
  return true;
}

double DihedralAngle(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  double theta = 0;
  DihedralAngleGradient(a, b, c, d, &theta, nullptr);
  return theta;
}

void BendingOptions::Validate() const {
  if (!(rigidity >= 0 && rigidity <= 1)) BadField(rigidity, "rigidity", "must be in [0, 1] N·m");
  if (!(scale > 0 && scale <= 100)) BadField(scale, "scale", "must be in (0, 100]");
  if (!(yield_curvature >= 0 && std::isfinite(yield_curvature)))
    BadField(yield_curvature, "yield_curvature", "must be ≥ 0 1/m (0: no plasticity)");
  if (!(weakening >= 0 && weakening <= 1000)) BadField(weakening, "weakening", "must be in [0, 1000]");
}

BendingModel MakeBendingModel(const TriMesh& rest, const std::vector<int>& layer, const BendingOptions& options,
                              const std::vector<double>& factor) {
  options.Validate();
  const int nv = rest.NumVertices(), nf = rest.NumFaces();
  if (!layer.empty() && static_cast<int>(layer.size()) != nv)
    throw Error("bending: layer has " + std::to_string(layer.size()) + " entries for " + std::to_string(nv) +
                " vertices");
  if (!factor.empty() && static_cast<int>(factor.size()) != nf)
    throw Error("bending: factor has " + std::to_string(factor.size()) + " entries for " + std::to_string(nf) +
                " faces");
  BendingModel m;
  m.options = options;
  // Directed edge (a, b) → the face that runs a → b and its opposite corner.
  std::map<std::pair<int, int>, std::pair<int, int>> directed;
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = rest.F(f, k), b = rest.F(f, (k + 1) % 3), c = rest.F(f, (k + 2) % 3);
      if (!directed.emplace(std::make_pair(a, b), std::make_pair(f, c)).second)
        throw Error("bending: the mesh is not consistently oriented (edge " + std::to_string(a) + "–" +
                    std::to_string(b) + " runs the same way in two faces)");
    }
  const Eigen::VectorXd area = FaceAreas(rest);
  auto face_layer = [&](int f) {
    int l = 0;
    for (int k = 0; k < 3; ++k) l = std::max(l, layer[rest.F(f, k)]);
    return l;
  };
  m.face_hinges.assign(nf, {-1, -1, -1});
  std::vector<double> rest_angle, stiffness;
  for (const auto& [ab, fc] : directed) {
    const auto [a, b] = ab;
    if (a > b) continue;  // each interior edge once, from its a < b direction
    const auto other = directed.find({b, a});
    if (other == directed.end()) continue;  // boundary edge
    Hinge h{a, b, fc.second, other->second.second, fc.first, other->second.first};
    const Vec3 pa = Row(rest.V, a), pb = Row(rest.V, b), pc = Row(rest.V, h.c), pd = Row(rest.V, h.d);
    const double theta = DihedralAngle(pa, pb, pc, pd);
    double rest_theta = theta;
    if (!layer.empty()) rest_theta = face_layer(h.face_c) != face_layer(h.face_d) ? std::copysign(kPi, theta) : 0.0;
    const double l2 = (pb - pa).squaredNorm(), a12 = area[h.face_c] + area[h.face_d];
    if (!(a12 > 0))
      throw Error("bending: faces " + std::to_string(h.face_c) + ", " + std::to_string(h.face_d) + " have no area");
    const double fac = factor.empty() ? 1.0 : 0.5 * (factor[h.face_c] + factor[h.face_d]);
    const int id = static_cast<int>(m.hinges.size());
    for (const int f : {h.face_c, h.face_d})
      for (int k = 0; k < 3; ++k) {
        const int u = rest.F(f, (k + 1) % 3), v = rest.F(f, (k + 2) % 3);  // edge opposite corner k
        if (std::min(u, v) == a && std::max(u, v) == b) m.face_hinges[f][k] = id;
      }
    m.hinges.push_back(h);
    rest_angle.push_back(rest_theta);
    stiffness.push_back(0.5 * options.scale * options.rigidity * fac * l2 / a12);
  }
  m.rest_angle = Eigen::Map<Eigen::VectorXd>(rest_angle.data(), static_cast<Eigen::Index>(rest_angle.size()));
  m.stiffness = Eigen::Map<Eigen::VectorXd>(stiffness.data(), static_cast<Eigen::Index>(stiffness.size()));
  if (m.plastic()) {
    m.edges_to_face.resize(nf);
    m.face_to_edges.resize(nf);
    for (int f = 0; f < nf; ++f) {
      m.edges_to_face[f] = EdgesToFace(Row(rest.V, rest.F(f, 0)), Row(rest.V, rest.F(f, 1)), Row(rest.V, rest.F(f, 2)));
      m.face_to_edges[f] = m.edges_to_face[f].inverse();
      if (!m.face_to_edges[f].allFinite())
        throw Error("bending: face " + std::to_string(f) + " is degenerate (plasticity needs its curvature)");
    }
  }
  return m;
}

BendingState InitialBendingState(const BendingModel& m) {
  BendingState s;
  s.rest_angle = m.rest_angle;
  if (m.plastic()) {
    const int nf = static_cast<int>(m.face_hinges.size());
    s.plastic = Points3::Zero(nf, 3);
    s.damage = Eigen::VectorXd::Zero(nf);
    for (int f = 0; f < nf; ++f) {
      Vec3 theta = Vec3::Zero();
      for (int k = 0; k < 3; ++k)
        if (m.face_hinges[f][k] >= 0) theta[k] = m.rest_angle[m.face_hinges[f][k]];
      s.plastic.row(f) = (m.edges_to_face[f] * theta).transpose();
    }
  }
  return s;
}

double BendingEnergy(const BendingModel& m, const BendingState& s, const Points3& x) {
  double e = 0;
  for (size_t h = 0; h < m.hinges.size(); ++h) {
    const Hinge& g = m.hinges[h];
    const double d = WrapAngle(DihedralAngle(Row(x, g.a), Row(x, g.b), Row(x, g.c), Row(x, g.d)) - s.rest_angle[h]);
    e += Stiffness(m, s, static_cast<int>(h)) * d * d;
  }
  return e;
}

void AddBendingForces(const BendingModel& m, const BendingState& s, const Points3& x, Points3& f) {
  std::array<Vec3, 4> g;
  for (size_t h = 0; h < m.hinges.size(); ++h) {
    const Hinge& e = m.hinges[h];
    double theta = 0;
    if (!DihedralAngleGradient(Row(x, e.a), Row(x, e.b), Row(x, e.c), Row(x, e.d), &theta, &g)) continue;
    const double k2 = -2 * Stiffness(m, s, static_cast<int>(h)) * WrapAngle(theta - s.rest_angle[h]);
    const int n[4] = {e.a, e.b, e.c, e.d};
    for (int i = 0; i < 4; ++i) f.row(n[i]) += (k2 * g[i]).transpose();
  }
}

double BendingFrequencySquared(const BendingModel& m, const BendingState& s, const Points3& x,
                               const Eigen::VectorXd& mass) {
  const int n = static_cast<int>(x.rows());
  // y = M^(−1/2)·H·M^(−1/2)·z with H = Σ 2k·g gᵀ, by hinges.
  std::vector<std::array<Vec3, 4>> grads(m.hinges.size());
  std::vector<double> k2(m.hinges.size());
  for (size_t h = 0; h < m.hinges.size(); ++h) {
    const Hinge& e = m.hinges[h];
    k2[h] = DihedralAngleGradient(Row(x, e.a), Row(x, e.b), Row(x, e.c), Row(x, e.d), nullptr, &grads[h])
                ? 2 * Stiffness(m, s, static_cast<int>(h))
                : 0;
  }
  Eigen::VectorXd w(n);  // M^(−1/2), 0 for held nodes
  for (int i = 0; i < n; ++i) w[i] = mass[i] > 0 && std::isfinite(mass[i]) ? 1 / std::sqrt(mass[i]) : 0;
  Points3 z(n, 3), y(n, 3);
  for (int i = 0; i < n; ++i) z.row(i) << 1 + 0.1 * std::sin(i), 1 + 0.1 * std::cos(3 * i), 1 + 0.1 * std::sin(5 * i);
  double lambda = 0;
  for (int it = 0; it < 100; ++it) {
    const double norm = z.norm();
    if (!(norm > 0)) return 0;
    z /= norm;
    y.setZero();
    for (size_t h = 0; h < m.hinges.size(); ++h) {
      if (k2[h] == 0) continue;
      const Hinge& e = m.hinges[h];
      const int nd[4] = {e.a, e.b, e.c, e.d};
      double dot = 0;
      for (int i = 0; i < 4; ++i) dot += w[nd[i]] * grads[h][i].dot(z.row(nd[i]).transpose());
      for (int i = 0; i < 4; ++i) y.row(nd[i]) += (k2[h] * dot * w[nd[i]] * grads[h][i]).transpose();
    }
    const double next = (z.array() * y.array()).sum();  // Rayleigh quotient, z normalised
    z = y;
    if (it > 10 && std::abs(next - lambda) <= 1e-3 * next) return std::max(next, lambda);
    lambda = next;
  }
  return lambda;
}

int UpdatePlasticity(const BendingModel& m, BendingState& s, const Points3& x) {
  if (!m.plastic()) return 0;
  const int nh = static_cast<int>(m.hinges.size()), nf = static_cast<int>(m.face_hinges.size());
  Eigen::VectorXd theta(nh);
  for (int h = 0; h < nh; ++h) {
    const Hinge& e = m.hinges[h];
    theta[h] = DihedralAngle(Row(x, e.a), Row(x, e.b), Row(x, e.c), Row(x, e.d));
  }
  const double yield = m.options.yield_curvature;
  std::vector<char> changed(nh, 0);
  int yielded = 0;
  for (int f = 0; f < nf; ++f) {
    // Elastic angles: each edge's angle from the rest angle the face's own plastic
    // tensor implies (wrapped, so a stitched fold at ±π stays continuous).
    const Vec3 sp = s.plastic.row(f).transpose();
    const Vec3 rest = m.face_to_edges[f] * sp;
    Vec3 elastic = Vec3::Zero();
    for (int k = 0; k < 3; ++k)
      if (m.face_hinges[f][k] >= 0) elastic[k] = WrapAngle(theta[m.face_hinges[f][k]] - rest[k]);
    const Vec3 se = m.edges_to_face[f] * elastic;
    // Frobenius norm of the symmetric 2×2 tensor (S00, S11, S01).
    const double norm = std::sqrt(se[0] * se[0] + se[1] * se[1] + 2 * se[2] * se[2]);
    if (!(norm > yield * (1 + 1e-9))) continue;  // on the yield surface (to rounding)
    s.plastic.row(f) += (se * (1 - yield / norm)).transpose();
    s.damage[f] += norm / yield - 1;
    ++yielded;
    for (int k = 0; k < 3; ++k)
      if (m.face_hinges[f][k] >= 0) changed[m.face_hinges[f][k]] = 1;
  }
  for (int h = 0; h < nh; ++h) {
    if (!changed[h]) continue;
    const Hinge& e = m.hinges[h];
    double sum = 0;
    for (const int f : {e.face_c, e.face_d}) {
      const Vec3 rest = m.face_to_edges[f] * s.plastic.row(f).transpose();
      for (int k = 0; k < 3; ++k)
        if (m.face_hinges[f][k] == h) sum += rest[k];
    }
    s.rest_angle[h] = 0.5 * sum;
  }
  return yielded;
}

}  // namespace drape
