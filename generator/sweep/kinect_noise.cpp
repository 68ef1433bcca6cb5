// Kinect v1 depth-noise model: exact ray-cast depth → a structured-light reading.
//
// Sources:
//  [N] C. V. Nguyen, S. Izadi, D. Lovell, "Modeling Kinect Sensor Noise for Improved 3D
//      Reconstruction and Tracking", 3DIMPVT 2012: axial σ_z(z, θ), lateral σ_L(θ).
//  [K] K. Khoshelham, S. O. Elberink, "Accuracy and Resolution of Kinect Depth Data for
//      Indoor Mapping Applications", Sensors 12(2), 2012: depth from disparity
//      Z = b·f/d, disparity quantised to 1/8 px, b ≈ 0.075 m, f ≈ 580 px, hence a depth
//      step ΔZ ≈ Z²/(8·b·f) = Z²/348 m.
//  Dropouts: a structured-light camera returns no data where the projected pattern is
//  not seen: surfaces at grazing angles, depth discontinuities (mixed pixels; [N] drops
//  θ > ~70–80° too), and the projector's shadow — points the camera sees but the
//  projector, 7.5 cm to the side [K], does not.
//
// Order (one 64-bit draw per pixel, raster order, whatever the pixel holds):
//   bits  0–15  lateral offset u     bits 32–47  axial noise
//   bits 16–31  lateral offset v     bits 48–63  dropout uniform
//  1. a plan from the exact image (no randomness): σ_z, σ_L, dropout probability
//     (grazing angle, depth edge), projector shadow — per pixel;
//  2. per source pixel: random dropouts, axial Gaussian noise, disparity
//     quantisation, range cut → a measurement;
//  3. lateral noise: pixel p reports the measurement of pixel p + round(σ_L(θ_p)·n),
//     n ~ N(0, 1) per axis (so a measurement may appear at two neighbouring pixels,
//     as the Kinect's block matching also correlates neighbours).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "common/field_error.h"
#include "generator/sweep/sweep.h"

namespace drape {
namespace detail {
// Value min/max (no NaN handling, no references): loops using them vectorise.
inline float Min(float a, float b) { return b < a ? b : a; }
inline float Max(float a, float b) { return a < b ? b : a; }
void NoiseParameters(const float* __restrict Zp, const float* __restrict Cp, float* __restrict sgp,
                     float* __restrict slp, float* __restrict pdp, size_t n, float big, float max_theta, float half_pi,
                     float sixty, float step, float bfq, float q12, float t0, float inv_ramp);
void DrawMeasurements(const float* __restrict Z, const float* __restrict sg, const float* __restrict pdrop,
                      const float* __restrict lit, const float* __restrict uni, const float* __restrict na,
                      float* __restrict out, size_t n, float axial, bool quantize, float bfq, float step, float zmin,
                      float zmax);
void LateralOffsets(const float* __restrict sl, const float* __restrict nu, const float* __restrict nv,
                    int8_t* __restrict du, int8_t* __restrict dv, size_t n);
}  // namespace detail
namespace {

// Standard normal quantiles at (k + 0.5)/65536: a 16-bit draw → N(0, 1) sample,
// tails to ±3.97σ. Acklam's rational approximation polished by two Halley steps.
double NormalQuantile(double p) {
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01, -1.328068155833272e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  const double plow = 0.02425;
  double x;
  if (p < plow) {
    double q = std::sqrt(-2 * std::log(p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  } else if (p <= 1 - plow) {
    double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  } else {
    double q = std::sqrt(-2 * std::log(1 - p));
    x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  }
  for (int it = 0; it < 2; ++it) {
    double e = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p;
    double u = e * std::sqrt(2 * M_PI) * std::exp(x * x / 2);
    x = x - u / (1 + x * u / 2);
  }
  return x;
}

const std::array<float, 65536>& NormalTable() {
  static const std::array<float, 65536> table = [] {
    std::array<float, 65536> t{};
    for (int k = 0; k < 65536; ++k) t[k] = float(NormalQuantile((k + 0.5) / 65536.0));
    return t;
  }();
  return table;
}

}  // namespace

namespace detail {
// Per-pixel noise parameters (see ApplyKinectNoise). A separate external function with
// restrict pointers and no control flow: GCC 12 vectorises it (not when inlined).
__attribute__((noinline)) void NoiseParameters(const float* __restrict Zp, const float* __restrict Cp,
                                               float* __restrict sgp, float* __restrict slp, float* __restrict pdp,
                                               size_t n, float big, float max_theta, float half_pi, float sixty,
                                               float step, float bfq, float q12, float t0, float inv_ramp) {
  for (size_t p = 0; p < n; ++p) {
    const float zz = Zp[p];
    const float finite = zz <= big ? 1.0f : 0.0f;
    const float z = detail::Min(zz, big);
    const float c = detail::Min(detail::Max(Cp[p], 0.0f), 1.0f);
    // acos (Abramowitz & Stegun 4.4.45, |error| < 7e-5 rad).
    const float th = std::sqrt(1.0f - c) * (1.5707288f + c * (-0.2121144f + c * (0.0742610f + c * -0.0187293f)));
    const float t = detail::Min(th, max_theta);
    const float r = t / (half_pi - t);
    // [N] σ_L = 0.8 + 0.035·θ/(π/2 − θ) px (θ capped at 85°; beyond it is dropped).
    slp[p] = 0.8f + 0.035f * r * finite;
    // [N] σ_z = 0.0012 + 0.0019·(z − 0.4)² m for θ ≤ 60°, plus
    // (0.0001/√z)·θ²/(π/2 − θ)² beyond 60° (their Eq. for large angles).
    const float beyond60 = t > sixty ? 1.0f : 0.0f;
    const float sz = 0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f) + beyond60 * 0.0001f / std::sqrt(z) * r * r;
    // [N] measured σ_z on real, quantised readings: when we quantise too, only the rest
    // is Gaussian (Sheppard: total variance ≈ σ_g² + ΔZ²/12, ΔZ = Z²·step/(b·f) [K]).
    const float dz = z * z * step / bfq;
    sgp[p] = std::sqrt(detail::Max(sz * sz - dz * dz * q12, 0.0f));
    // Grazing dropout probability: 0 below grazing_start, linear to 1 at grazing_full.
    pdp[p] = detail::Min(detail::Max((th - t0) * inv_ramp, 0.0f), 1.0f);
  }
}

// Measured depth of every source pixel: axial noise, disparity quantisation, random
// dropouts, range cut (0 = no data). Branch-free (vectorised).
__attribute__((noinline)) void DrawMeasurements(const float* __restrict Z, const float* __restrict sg,
                                                const float* __restrict pdrop, const float* __restrict lit,
                                                const float* __restrict uni, const float* __restrict na,
                                                float* __restrict out, size_t n, float axial, bool quantize, float bfq,
                                                float step, float zmin, float zmax) {
  const float qk = quantize ? 1.0f : 0.0f;
  for (size_t p = 0; p < n; ++p) {
    float z = Min(Z[p], 1e6f) + axial * sg[p] * na[p];
    // [K] disparity d = b·f/Z, quantised to 1/8 px (round half up; clamped to stay an int).
    // The argument is >= 0, so truncating after + 0.5 rounds half up; lround would differ
    // where x + 0.5f itself rounds (x = 0.49999997f), and the sensed bytes must not move.
    // NOLINTNEXTLINE(bugprone-incorrect-roundings)
    const float k = float(int(Min(Max(bfq / (z * step), 0.0f), 1e7f) + 0.5f));
    const float zq = bfq / (Max(k, 0.5f) * step);
    z = qk * zq + (1.0f - qk) * z;
    // Kept: lit, not dropped, in range, and a positive disparity when quantised.
    const float keep = lit[p] * (uni[p] >= pdrop[p] ? 1.0f : 0.0f) * (z >= zmin ? 1.0f : 0.0f) *
                       (z <= zmax ? 1.0f : 0.0f) * (k > 0.0f ? 1.0f : 1.0f - qk);
    out[p] = keep > 0.0f ? z : 0.0f;
  }
}

// Lateral offsets round(σ_L·n) per axis (round to nearest without libm; +64 keeps the
// argument positive).
__attribute__((noinline)) void LateralOffsets(const float* __restrict sl, const float* __restrict nu,
                                              const float* __restrict nv, int8_t* __restrict du, int8_t* __restrict dv,
                                              size_t n) {
  for (size_t p = 0; p < n; ++p) {
    du[p] = int8_t(int(Min(Max(sl[p] * nu[p], -60.0f), 60.0f) + 64.5f) - 64);
    dv[p] = int8_t(int(Min(Max(sl[p] * nv[p], -60.0f), 60.0f) + 64.5f) - 64);
  }
}

}  // namespace detail

void KinectOptions::Validate() const {
  const Intrinsics& in = intrinsics;
  if (in.width < 8 || in.width > 8192) BadField(in.width, "kinect.intrinsics.width", "must be in 8..8192 px");
  if (in.height < 8 || in.height > 8192) BadField(in.height, "kinect.intrinsics.height", "must be in 8..8192 px");
  if (!(in.fx > 0 && in.fx <= 1e5)) BadField(in.fx, "kinect.intrinsics.fx", "must be in (0, 1e5] px");
  if (!(in.fy > 0 && in.fy <= 1e5)) BadField(in.fy, "kinect.intrinsics.fy", "must be in (0, 1e5] px");
  if (!(std::abs(in.cx) <= 1e5)) BadField(in.cx, "kinect.intrinsics.cx", "must be in [-1e5, 1e5] px");
  if (!(std::abs(in.cy) <= 1e5)) BadField(in.cy, "kinect.intrinsics.cy", "must be in [-1e5, 1e5] px");
  if (!(min_range > 0)) BadField(min_range, "kinect.min_range", "must be > 0");
  if (!(max_range > min_range && max_range <= 100))
    BadField(max_range, "kinect.max_range", "must be > min_range and <= 100 m");
  if (!(baseline > 0)) BadField(baseline, "kinect.baseline", "must be > 0");
  if (!(disparity_focal > 0)) BadField(disparity_focal, "kinect.disparity_focal", "must be > 0");
  if (!(disparity_subpixel > 0 && disparity_subpixel <= 1))
    BadField(disparity_subpixel, "kinect.disparity_subpixel", "must be in (0, 1]");
  if (!(grazing_start_deg > 0 && grazing_start_deg <= grazing_full_deg && grazing_full_deg <= 90))
    BadField(grazing_start_deg, "kinect.grazing_start_deg/grazing_full_deg", "need 0 < start <= full <= 90");
  if (!(edge_jump > 0)) BadField(edge_jump, "kinect.edge_jump", "must be > 0");
  if (!(edge_dropout_probability >= 0 && edge_dropout_probability <= 1))
    BadField(edge_dropout_probability, "kinect.edge_dropout_probability", "must be in [0, 1]");
}

namespace {

void CheckSizes(const ExactFrame& exact, const KinectOptions& o) {
  const size_t n = size_t(o.intrinsics.width) * o.intrinsics.height;
  DRAPE_CHECK(exact.depth.size() == n && exact.cos_incidence.size() == n,
              "exact frame size does not match the intrinsics");
}

}  // namespace

void UpdateKinectPlan(const ExactFrame& exact, const KinectOptions& o, const PixelRect& region, KinectPlan& plan) {
  CheckSizes(exact, o);
  const int W = o.intrinsics.width, H = o.intrinsics.height;
  const size_t n = size_t(W) * H;
  if (plan.sigma_axial.size() != n) {
    plan.sigma_axial.assign(n, 0.0f);
    plan.sigma_lateral.assign(n, 0.0f);
    plan.p_drop.assign(n, 0.0f);
    plan.lit.assign(n, 0.0f);
    plan.shadow_suffix.assign(n, std::numeric_limits<float>::infinity());
  }
  const int u0 = std::clamp(region.u0, 0, W), u1 = std::clamp(region.u1, 0, W);
  const int v0 = std::clamp(region.v0, 0, H), v1 = std::clamp(region.v1, 0, H);
  if (u1 <= u0 || v1 <= v0) return;
  const float* Z = exact.depth.data();
  const float* C = exact.cos_incidence.data();
  const float zmax = float(o.max_range);
  const float half_pi = float(M_PI / 2), max_theta = float(85 * M_PI / 180);
  const float sixty = float(M_PI / 3);
  const float t0 = float(o.grazing_start_deg * M_PI / 180), t1 = float(o.grazing_full_deg * M_PI / 180);
  const float bfq = float(o.baseline * o.disparity_focal);  // m·px, [K]
  const float step = float(o.disparity_subpixel);           // px
  // Loop invariants as factors, so that the parameter loop has no control flow.
  const float q12 = o.quantize ? 1.0f / 12.0f : 0.0f;
  const float inv_ramp = t1 > t0 ? 1.0f / (t1 - t0) : 1e30f;
  const float big = zmax * 4;  // farther (and +inf = nothing hit) counts as no surface
  const float jump = float(o.edge_jump), pe = float(o.edge_dropout_probability);
  const bool edges = o.dropouts && o.edge_dropout_probability > 0;
  const bool shadow = o.dropouts && o.projector_shadow;
  const float bf = float(o.baseline * o.intrinsics.fx);
  for (int v = v0; v < v1; ++v) {
    const size_t row = size_t(v) * W;
    detail::NoiseParameters(Z + row + u0, C + row + u0, plan.sigma_axial.data() + row + u0,
                            plan.sigma_lateral.data() + row + u0, plan.p_drop.data() + row + u0, size_t(u1 - u0), big,
                            max_theta, half_pi, sixty, step, bfq, q12, t0, inv_ramp);
    float* pd = plan.p_drop.data() + row;
    if (!o.dropouts) std::fill(pd + u0, pd + u1, 0.0f);
    // Projector shadow (deterministic). Projector at +baseline along camera x (Kinect v1:
    // projector at the camera's right, so shadows fall on the left of near objects). A
    // point at column u and depth z is lit at projector column u − b·f/z; scanning towards
    // the projector, it is in shadow if a point between it and the projector is lit at a
    // smaller projector column. The scan starts from the stored suffix minimum right of
    // the region.
    float m = u1 < W ? plan.shadow_suffix[row + u1] : std::numeric_limits<float>::infinity();
    for (int u = u1 - 1; u >= u0; --u) {
      const size_t p = row + u;
      const bool surface = Z[p] <= big;
      float lit = surface ? 1.0f : 0.0f;
      if (surface) {
        const float up = float(u) - bf / Z[p];
        if (shadow && up > m + 0.25f) lit = 0.0f;
        m = std::min(m, up);
      }
      plan.lit[p] = lit;
      plan.shadow_suffix[p] = m;
    }
    if (edges) {
      // Depth edge: a 4-neighbour differs by more than edge_jump (or has no surface).
      for (int u = u0; u < u1; ++u) {
        const size_t p = row + u;
        const float z = Z[p];
        bool e = false;
        if (u > 0) e |= !(std::abs(Z[p - 1] - z) <= jump);
        if (u + 1 < W) e |= !(std::abs(Z[p + 1] - z) <= jump);
        if (v > 0) e |= !(std::abs(Z[p - W] - z) <= jump);
        if (v + 1 < H) e |= !(std::abs(Z[p + W] - z) <= jump);
        if (e) pd[u] = 1.0f - (1.0f - pd[u]) * (1.0f - pe);
      }
    }
  }
}

KinectPlan PlanKinectNoise(const ExactFrame& exact, const KinectOptions& o) {
  KinectPlan plan;
  UpdateKinectPlan(exact, o, PixelRect{0, 0, o.intrinsics.width, o.intrinsics.height}, plan);
  return plan;
}

std::vector<float> DrawKinectNoise(const ExactFrame& exact, const KinectPlan& plan, const KinectOptions& o, Rng& rng,
                                   KinectScratch* scratch) {
  CheckSizes(exact, o);
  const int W = o.intrinsics.width, H = o.intrinsics.height;
  const size_t n = size_t(W) * H;
  const float zmin = float(o.min_range), zmax = float(o.max_range);
  const float* Z = exact.depth.data();
  std::vector<float> out(n, 0.0f);
  if (!o.noise) {
    for (size_t p = 0; p < n; ++p) out[p] = (Z[p] >= zmin && Z[p] <= zmax) ? Z[p] : 0.0f;
    return out;
  }
  DRAPE_CHECK(plan.sigma_axial.size() == n, "noise plan size does not match the intrinsics");
  const auto& N = NormalTable();
  KinectScratch local;
  KinectScratch& s = scratch ? *scratch : local;
  // Sized without clearing: every element is written below.
  s.na.resize(n);
  s.uni.resize(n);
  s.nu.resize(n);
  s.nv.resize(n);
  s.measured.resize(n);
  s.du.resize(n);
  s.dv.resize(n);
  auto& na = s.na;
  auto& uni = s.uni;
  auto& nu = s.nu;
  auto& nv = s.nv;
  // One 64-bit draw per pixel, raster order, split into table look-ups (scalar); the
  // arithmetic follows in branch-free loops (vectorised).
  for (size_t p = 0; p < n; ++p) {
    const uint64_t b = rng.NextU64();
    nu[p] = N[b & 0xFFFF];
    nv[p] = N[(b >> 16) & 0xFFFF];
    na[p] = N[(b >> 32) & 0xFFFF];
    uni[p] = (float(int(b >> 48)) + 0.5f) * (1.0f / 65536.0f);
  }
  const float bfq = float(o.baseline * o.disparity_focal);  // m·px, [K]
  const float step = float(o.disparity_subpixel);
  auto& measured = s.measured;
  detail::DrawMeasurements(Z, plan.sigma_axial.data(), plan.p_drop.data(), plan.lit.data(), uni.data(), na.data(),
                           measured.data(), n, o.axial ? 1.0f : 0.0f, o.quantize, bfq, step, zmin, zmax);
  if (!o.lateral) return measured;
  // Lateral noise: pixel p reports the measurement of pixel p + round(σ_L·n) per axis.
  auto& du = s.du;
  auto& dv = s.dv;
  detail::LateralOffsets(plan.sigma_lateral.data(), nu.data(), nv.data(), du.data(), dv.data(), n);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t p = size_t(v) * W + u;
      const int uu = u + du[p], vv = v + dv[p];
      if (uu < 0 || uu >= W || vv < 0 || vv >= H) continue;
      out[p] = measured[size_t(vv) * W + uu];
    }
  }
  return out;
}

std::vector<float> ApplyKinectNoise(const ExactFrame& exact, const KinectOptions& o, Rng& rng) {
  if (!o.noise) return DrawKinectNoise(exact, KinectPlan{}, o, rng);
  return DrawKinectNoise(exact, PlanKinectNoise(exact, o), o, rng);
}

}  // namespace drape
