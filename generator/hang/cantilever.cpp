#include "generator/hang/cantilever.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>
#include <unordered_map>

#include "common/error.h"
#include "common/field_error.h"
#include "common/format.h"

namespace drape {
namespace {

struct Shot {
  double theta = 0, dtheta = 0;  // at the tip (t = 1)
  double x = 0, y = 0;           // tip / L
};

// θ'' = −γ·(1 − t)·cos θ from θ(0) = 0, θ'(0) = p; x' = cos θ, y' = −sin θ.
Shot Integrate(double gamma, double p) {
  constexpr int kSteps = 2000;
  const double h = 1.0 / kSteps;
  double th = 0, dth = p, x = 0, y = 0;
  auto acc = [&](double t, double a) { return -gamma * (1 - t) * std::cos(a); };
  for (int i = 0; i < kSteps; ++i) {
    const double t = i * h;
    const double k1t = dth, k1d = acc(t, th), k1x = std::cos(th), k1y = -std::sin(th);
    const double a2 = th + 0.5 * h * k1t, d2 = dth + 0.5 * h * k1d;
    const double k2t = d2, k2d = acc(t + 0.5 * h, a2), k2x = std::cos(a2), k2y = -std::sin(a2);
    const double a3 = th + 0.5 * h * k2t, d3 = dth + 0.5 * h * k2d;
    const double k3t = d3, k3d = acc(t + 0.5 * h, a3), k3x = std::cos(a3), k3y = -std::sin(a3);
    const double a4 = th + h * k3t, d4 = dth + h * k3d;
    const double k4t = d4, k4d = acc(t + h, a4), k4x = std::cos(a4), k4y = -std::sin(a4);
    th += h / 6 * (k1t + 2 * k2t + 2 * k3t + k4t);
    dth += h / 6 * (k1d + 2 * k2d + 2 * k3d + k4d);
    x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
    y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y);
  }
  return {th, dth, x, y};
}

}  // namespace

ElasticaTip HeavyElastica(double gamma) {
  if (!(gamma >= 0 && std::isfinite(gamma))) throw Error("heavy elastica: γ must be finite and ≥ 0");
  // θ'(1) grows with θ'(0); the root lies in [0, γ/2] (γ/2: the small-deflection
  // root curvature, which the weight's shrinking lever only lowers).
  double lo = 0, hi = gamma / 2;
  for (int it = 0; it < 100 && hi - lo > 1e-14 * (1 + hi); ++it) {
    const double mid = 0.5 * (lo + hi);
    (Integrate(gamma, mid).dtheta > 0 ? hi : lo) = mid;
  }
  const double p = 0.5 * (lo + hi);
  const Shot s = Integrate(gamma, p);
  ElasticaTip tip;
  tip.x = s.x;
  tip.y = s.y;
  tip.chord_angle = std::atan2(-s.y, s.x);
  tip.root_curvature = p;
  return tip;
}

namespace {

// HeavyElastica(exp(log_gamma)).chord_angle, remembered by the exact log γ. The bisection
// below asks for the same points again: every call starts from the same bracket (a
// material fit asks for chord angles close to each other, whose first steps coincide),
// and its last ~25 of 80 steps find the bracket's ends adjacent doubles and repeat an
// end. A pure function: the answer is the same bit for bit, only not recomputed (the
// elastica was ~70 % of a material fit's time).
double ChordAngleAtLogGamma(double log_gamma) {
  static std::mutex mutex;
  static std::unordered_map<double, double> known;
  constexpr size_t kMaxKnown = 1 << 16;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    const auto it = known.find(log_gamma);
    if (it != known.end()) return it->second;
  }
  const double chord = HeavyElastica(std::exp(log_gamma)).chord_angle;
  const std::lock_guard<std::mutex> lock(mutex);
  if (known.size() >= kMaxKnown) known.clear();
  known.emplace(log_gamma, chord);
  return chord;
}

}  // namespace

double ElasticaGammaForChordAngle(double chord_angle) {
  if (!(chord_angle > 0 && chord_angle < std::numbers::pi / 2))
    throw Error("heavy elastica: the chord angle must be in (0, 90°), got " +
                FormatNumber(chord_angle * 180 / std::numbers::pi) + "°");
  // The chord angle grows with γ; bisection on log γ.
  double lo = -12, hi = 12;
  for (int it = 0; it < 80; ++it) {
    const double mid = 0.5 * (lo + hi);
    (ChordAngleAtLogGamma(mid) < chord_angle ? lo : hi) = mid;
  }
  return std::exp(0.5 * (lo + hi));
}

void CantileverOptions::Validate() const {
  if (!(width > 0.002 && width < 1)) BadField(width, "width", "must be in (0.002, 1) m");
  if (!(overhang >= 0 && overhang < 2)) BadField(overhang, "overhang", "must be in [0, 2) m (0: twice the expected c)");
  if (!(held > 0 && held < 1)) BadField(held, "held", "must be in (0, 1) m");
  if (!(edge_length > 0.001 && edge_length < 0.2)) BadField(edge_length, "edge_length", "must be in (0.001, 0.2) m");
  if (!(settle_time > 0.5 && settle_time <= 60)) BadField(settle_time, "settle_time", "must be in (0.5, 60] s");
}

CantileverResult RunCantilever(const Material& material, const MaterialFit& fit, const HangOptions& hang,
                               const CantileverOptions& o) {
  o.Validate();
  material.Validate();
  const double w = material.area_density * 9.81;
  double L = o.overhang;
  if (L == 0) {
    if (!(material.bending_rigidity > 0))
      throw Error("cantilever: material '" + material.name + "' has no bending rigidity to size the overhang by");
    L = 2 * material.BendingLength();
  }
  // Rows about edge_length apart with the platform edge on a row.
  const int free_rows = std::max(1, static_cast<int>(std::lround(L / o.edge_length)));
  const double row = L / free_rows;
  const int held_rows = std::max(1, static_cast<int>(std::lround(o.held / row)));
  const Garment strip = MakeRectangleGarment(o.width, (free_rows + held_rows) * row, row, false);
  // Pattern (x, y) → world (x, 0, y − held): the platform edge at z = 0, the overhang
  // towards +z, y up; the rows at pattern y ≤ held lie on the platform.
  const double held_len = held_rows * row;
  const int n = strip.mesh.NumVertices();
  Points3 start(n, 3);
  for (int i = 0; i < n; ++i) start.row(i) << strip.mesh.V(i, 0), 0, strip.mesh.V(i, 1) - held_len;
  std::vector<int> on_platform, tip_row, edge_row;
  const double eps = 1e-9 * row;
  for (int i = 0; i < n; ++i) {
    if (start(i, 2) <= eps) on_platform.push_back(i);
    if (std::abs(start(i, 2)) <= eps) edge_row.push_back(i);
    if (start(i, 2) >= L - eps) tip_row.push_back(i);
  }
  ClothOptions co = ClothOptionsFor(hang, hang.time_step);
  auto model = MakeClothModel(TriMesh{start, strip.mesh.F}, {}, ClothMaterialFor(material, fit, hang), co);
  ClothWorld world(model, start);
  const int g = world.AddGripper(Jaw{}, Eigen::Isometry3d::Identity());
  world.Hold(g, on_platform);
  CantileverResult r;
  r.overhang = L;
  r.nodes = n;
  r.substeps = model->substeps;
  Points3 before;
  const int steps = static_cast<int>(std::ceil(o.settle_time / co.time_step));
  const int window = static_cast<int>(std::lround(0.25 / co.time_step));
  for (int s = 0; s < steps; ++s) {
    if (s == steps - window) before = world.positions();
    world.Step();
  }
  r.failure = world.Health();
  const Points3& x = world.positions();
  r.motion = (x - before).rowwise().norm().maxCoeff();
  Vec3 edge = Vec3::Zero(), tip = Vec3::Zero();
  for (int i : edge_row) edge += x.row(i).transpose();
  for (int i : tip_row) tip += x.row(i).transpose();
  edge /= static_cast<double>(edge_row.size());
  tip /= static_cast<double>(tip_row.size());
  const double along = tip.z() - edge.z(), drop = edge.y() - tip.y();
  r.tip_drop = drop;
  r.chord_angle = std::atan2(drop, along);
  if (!r.failure.empty() || !(r.chord_angle > 1e-6 && r.chord_angle < std::numbers::pi / 2 - 1e-6)) {
    if (r.failure.empty()) r.failure = "tip chord at " + FormatNumber(r.chord_angle * 180 / std::numbers::pi) + "°";
    return r;
  }
  r.gamma = ElasticaGammaForChordAngle(r.chord_angle);
  r.bending_rigidity = w * L * L * L / r.gamma;
  r.bending_length = std::cbrt(r.bending_rigidity / w);
  return r;
}

}  // namespace drape
