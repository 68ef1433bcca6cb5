#include "runtime/registration/energy.h"

#include <cmath>

#include "common/error.h"

namespace drape::registration {

namespace {
constexpr double kTiny = 1e-20;

Vec3 X(const Eigen::VectorXd& x, int v) { return x.segment<3>(3 * Eigen::Index{v}); }

// Unit vector of the component of v orthogonal to u (zero if degenerate).
Vec3 PerpUnit(const Vec3& v, const Vec3& u) {
  const double uu = u.squaredNorm();
  if (uu < kTiny) return Vec3::Zero();
  const Vec3 w = v - (v.dot(u) / uu) * u;
  const double n = w.norm();
  return n > 0 ? Vec3(w / n) : Vec3::Zero();
}
}  // namespace

double TriangleArea(const Vec3& a, const Vec3& b, const Vec3& c, Eigen::Matrix<double, 9, 1>* grad) {
  const Vec3 N = (b - a).cross(c - a);
  const double n = N.norm();
  if (grad) {
    if (n < kTiny) {
      grad->setZero();
    } else {
      const Vec3 nh = N / n;
      // ∂A/∂a = ½ n̂ × (c − b), cyclically.
      grad->segment<3>(0) = 0.5 * nh.cross(c - b);
      grad->segment<3>(3) = 0.5 * nh.cross(a - c);
      grad->segment<3>(6) = 0.5 * nh.cross(b - a);
    }
  }
  return 0.5 * n;
}

double CornerAngle(const Vec3& a, const Vec3& b, const Vec3& c, Eigen::Matrix<double, 9, 1>* grad) {
  const Vec3 u = b - a, v = c - a;
  const double theta = std::atan2(u.cross(v).norm(), u.dot(v));
  if (grad) {
    const double lu = u.norm(), lv = v.norm();
    if (lu < 1e-300 || lv < 1e-300) {
      grad->setZero();
    } else {
      // Moving b towards c's side (orthogonally to u) closes the angle.
      const Vec3 gb = -PerpUnit(v, u) / lu;
      const Vec3 gc = -PerpUnit(u, v) / lv;
      grad->segment<3>(0) = -(gb + gc);
      grad->segment<3>(3) = gb;
      grad->segment<3>(6) = gc;
    }
  }
  return theta;
}

double HingeAngle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, Eigen::Matrix<double, 12, 1>* grad) {
  const Vec3 e = x1 - x0;
  const Vec3 NA = e.cross(x2 - x0);          // face A = (x0, x1, x2)
  const Vec3 NB = (x0 - x1).cross(x3 - x1);  // face B = (x1, x0, x3)
  const double le = e.norm(), nA = NA.norm(), nB = NB.norm();
  if (le < 1e-300 || nA < kTiny || nB < kTiny) {
    if (grad) grad->setZero();
    return 0;
  }
  const Vec3 ea = e / le, a = NA / nA, b = NB / nB;
  const double theta = std::atan2(a.cross(b).dot(ea), a.dot(b));
  if (grad) {
    // ∂θ/∂x2 = −n̂_A / h_A, ∂θ/∂x3 = −n̂_B / h_B (h = height over the edge); the edge
    // vertices take the lever-rule shares so that translations leave θ unchanged.
    const Vec3 g2 = -NA * (le / (nA * nA));
    const Vec3 g3 = -NB * (le / (nB * nB));
    const double s2 = (x2 - x0).dot(e) / (le * le), s3 = (x3 - x0).dot(e) / (le * le);
    grad->segment<3>(0) = -(1 - s2) * g2 - (1 - s3) * g3;
    grad->segment<3>(3) = -s2 * g2 - s3 * g3;
    grad->segment<3>(6) = g2;
    grad->segment<3>(9) = g3;
  }
  return theta;
}

Eigen::VectorXd RegistrationEnergy::Flatten(const Points3& V) {
  Eigen::VectorXd x(3 * V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i) x.segment<3>(3 * i) = V.row(i).transpose();
  return x;
}

Points3 RegistrationEnergy::Unflatten(const Eigen::VectorXd& x) {
  Points3 V(x.size() / 3, 3);
  for (Eigen::Index i = 0; i < V.rows(); ++i) V.row(i) = x.segment<3>(3 * i).transpose();
  return V;
}

RegistrationEnergy::RegistrationEnergy(const TriMesh& rest, ClosestPointFn closest, const EnergyWeights& w)
    : F_(rest.F), num_vertices_(rest.NumVertices()), num_faces_(rest.NumFaces()), closest_(std::move(closest)) {
  DRAPE_CHECK(closest_ != nullptr, "no closest-point function");
  const int nf = num_faces_;
  fit_w_.resize(nf);
  area_w_.resize(nf);
  rest_area_.resize(nf);
  angle_w_.resize(nf, 3);
  rest_angle_.resize(nf, 3);
  for (int f = 0; f < nf; ++f) {
    const Vec3 p[3] = {rest.V.row(F_(f, 0)), rest.V.row(F_(f, 1)), rest.V.row(F_(f, 2))};
    const double A = TriangleArea(p[0], p[1], p[2], nullptr);
    rest_area_[f] = A;
    fit_w_[f] = std::sqrt(A);
    const bool ok = A > 1e-14;
    area_w_[f] = ok ? std::sqrt(w.kappa * A / 2) : 0.0;
    for (int k = 0; k < 3; ++k) {
      const double th = CornerAngle(p[k], p[(k + 1) % 3], p[(k + 2) % 3], nullptr);
      rest_angle_(f, k) = th;
      angle_w_(f, k) = (ok && th > 1e-9) ? std::sqrt(w.beta * A / 6) : 0.0;
    }
  }
  // Hinges: interior manifold edges. The edge is taken in face A's winding; face B's
  // normal is built from the same edge reversed, so the hinge does not depend on
  // whether B is consistently oriented.
  const EdgeTopology topo = BuildEdgeTopology(rest);
  for (const EdgeFaces& ef : topo.edges) {
    if (ef.faces[1] < 0) continue;
    const int fa = ef.faces[0], fb = ef.faces[1];
    int x0 = -1, x1 = -1, x2 = -1, x3 = -1;
    for (int k = 0; k < 3; ++k) {
      const int u = F_(fa, k), v = F_(fa, (k + 1) % 3);
      if ((u == ef.edge[0] && v == ef.edge[1]) || (u == ef.edge[1] && v == ef.edge[0])) {
        x0 = u, x1 = v, x2 = F_(fa, (k + 2) % 3);
      }
    }
    for (int k = 0; k < 3; ++k) {
      const int u = F_(fb, k);
      if (u != ef.edge[0] && u != ef.edge[1]) x3 = u;
    }
    DRAPE_CHECK(x0 >= 0 && x3 >= 0, "edge topology inconsistent with faces");
    const Vec3 p0 = rest.V.row(x0), p1 = rest.V.row(x1), p2 = rest.V.row(x2), p3 = rest.V.row(x3);
    const double le = (p1 - p0).norm();
    Hinge h{{x0, x1, x2, x3}, HingeAngle(p0, p1, p2, p3, nullptr), 0.0};
    if (le > 1e-12) {
      const double hA = 2 * rest_area_[fa] / le, hB = 2 * rest_area_[fb] / le;
      const double hbar = (hA + hB) / 3;
      if (hbar > 1e-12) h.weight = std::sqrt(w.alpha * le / hbar);
    }
    hinges_.push_back(h);
  }
  rows_ = 5 * nf + static_cast<int>(hinges_.size());
}

void RegistrationEnergy::Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const {
  DRAPE_CHECK(x.size() == NumParameters(), "parameter vector size");
  r.resize(rows_);
  for (int f = 0; f < num_faces_; ++f) {
    const Vec3 a = X(x, F_(f, 0)), b = X(x, F_(f, 1)), c = X(x, F_(f, 2));
    r[f] = fit_w_[f] * closest_((a + b + c) / 3).distance;
    r[num_faces_ + f] = area_w_[f] > 0 ? area_w_[f] * (TriangleArea(a, b, c, nullptr) / rest_area_[f] - 1) : 0;
    const Vec3 p[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      const double w = angle_w_(f, k);
      r[2 * num_faces_ + 3 * f + k] =
          w > 0 ? w * (CornerAngle(p[k], p[(k + 1) % 3], p[(k + 2) % 3], nullptr) / rest_angle_(f, k) - 1) : 0;
    }
  }
  const Eigen::Index hinge_rows = 5 * Eigen::Index{num_faces_};
  for (size_t e = 0; e < hinges_.size(); ++e) {
    const Hinge& h = hinges_[e];
    r[hinge_rows + e] =
        h.weight > 0
            ? h.weight * (HingeAngle(X(x, h.v[0]), X(x, h.v[1]), X(x, h.v[2]), X(x, h.v[3]), nullptr) - h.rest_angle)
            : 0;
  }
}

void RegistrationEnergy::Jacobian(const Eigen::VectorXd& x, SparseRowMatrix& J) const {
  DRAPE_CHECK(x.size() == NumParameters(), "parameter vector size");
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(size_t(num_faces_) * (9 + 9 + 27) + hinges_.size() * 12);
  auto put = [&](int row, const int* verts, int nv, const double* g, double scale) {
    for (int i = 0; i < nv; ++i)
      for (int d = 0; d < 3; ++d) t.emplace_back(row, 3 * verts[i] + d, scale * g[3 * i + d]);
  };
  Eigen::Matrix<double, 9, 1> g9;
  for (int f = 0; f < num_faces_; ++f) {
    const int vs[3] = {F_(f, 0), F_(f, 1), F_(f, 2)};
    const Vec3 p[3] = {X(x, vs[0]), X(x, vs[1]), X(x, vs[2])};
    // Fit: ∂dist/∂g = (g − cp)/dist (the distance field's gradient), g = mean of corners.
    const Vec3 g = (p[0] + p[1] + p[2]) / 3;
    const ClosestPoint c = closest_(g);
    const Vec3 n = c.distance > 1e-12 ? Vec3((g - c.point) / c.distance) : Vec3::Zero();
    for (Eigen::Index i = 0; i < 3; ++i) g9.segment<3>(3 * i) = n / 3;
    put(f, vs, 3, g9.data(), fit_w_[f]);
    TriangleArea(p[0], p[1], p[2], &g9);
    put(num_faces_ + f, vs, 3, g9.data(), area_w_[f] / rest_area_[f]);
    for (int k = 0; k < 3; ++k) {
      const int vk[3] = {vs[k], vs[(k + 1) % 3], vs[(k + 2) % 3]};
      CornerAngle(p[k], p[(k + 1) % 3], p[(k + 2) % 3], &g9);
      const double w = angle_w_(f, k);
      put(2 * num_faces_ + 3 * f + k, vk, 3, g9.data(), w > 0 ? w / rest_angle_(f, k) : 0.0);
    }
  }
  Eigen::Matrix<double, 12, 1> g12;
  for (size_t e = 0; e < hinges_.size(); ++e) {
    const Hinge& h = hinges_[e];
    HingeAngle(X(x, h.v[0]), X(x, h.v[1]), X(x, h.v[2]), X(x, h.v[3]), &g12);
    put(5 * num_faces_ + static_cast<int>(e), h.v, 4, g12.data(), h.weight);
  }
  J.resize(rows_, NumParameters());
  // Duplicates (a vertex repeated in a degenerate face) are summed.
  J.setFromTriplets(t.begin(), t.end());
}

EnergyTerms RegistrationEnergy::TermsFromResiduals(const Eigen::VectorXd& r) const {
  EnergyTerms e;
  const Eigen::Index nf = num_faces_;
  e.fit = r.segment(0, nf).squaredNorm();
  e.area = r.segment(nf, nf).squaredNorm();
  e.angle = r.segment(2 * nf, 3 * nf).squaredNorm();
  e.hinge = r.segment(5 * nf, hinges_.size()).squaredNorm();
  return e;
}

EnergyTerms RegistrationEnergy::Terms(const Eigen::VectorXd& x) const {
  Eigen::VectorXd r;
  Residuals(x, r);
  return TermsFromResiduals(r);
}

}  // namespace drape::registration
