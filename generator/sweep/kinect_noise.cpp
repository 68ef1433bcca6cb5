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
//  1. projector shadow on the exact image;
//  2. per source pixel: grazing/edge dropouts, axial Gaussian noise, disparity
//     quantisation, range cut → a measurement;
//  3. lateral noise: pixel p reports the measurement of pixel p + round(σ_L(θ_p)·n),
//     n ~ N(0, 1) per axis (so a measurement may appear at two neighbouring pixels,
//     as the Kinect's block matching also correlates neighbours).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "generator/sweep/sweep.h"

namespace drape {
namespace detail {
// Value min/max (no NaN handling, no references): loops using them vectorise.
inline float Min(float a, float b) { return b < a ? b : a; }
inline float Max(float a, float b) { return a < b ? b : a; }
void NoiseParameters(const float* __restrict Zp, const float* __restrict Cp, float* __restrict sgp,
                     float* __restrict slp, float* __restrict pdp, size_t n, float big,
                     float max_theta, float half_pi, float sixty, float step, float bfq, float q12,
                     float t0, float inv_ramp);
}  // namespace detail
namespace {

// Standard normal quantiles at (k + 0.5)/65536: a 16-bit draw → N(0, 1) sample,
// tails to ±3.97σ. Acklam's rational approximation polished by two Halley steps.
double NormalQuantile(double p) {
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,
                             -2.759285104469687e+02, 1.383577518672690e+02,
                             -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02,
                             -1.556989798598866e+02, 6.680131188771972e+01,
                             -1.328068155833272e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01,
                             -2.400758277161838e+00, -2.549732539343734e+00,
                             4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01,
                             2.445134137142996e+00, 3.754408661907416e+00};
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
__attribute__((noinline)) void NoiseParameters(const float* __restrict Zp, const float* __restrict Cp, float* __restrict sgp,
                     float* __restrict slp, float* __restrict pdp, size_t n, float big,
                     float max_theta, float half_pi, float sixty, float step, float bfq, float q12,
                     float t0, float inv_ramp) {
  for (size_t p = 0; p < n; ++p) {
    const float zz = Zp[p];
    const float finite = zz <= big ? 1.0f : 0.0f;
    const float z = detail::Min(zz, big);
    const float c = detail::Min(detail::Max(Cp[p], 0.0f), 1.0f);
    // acos (Abramowitz & Stegun 4.4.45, |error| < 7e-5 rad).
    const float th = std::sqrt(1.0f - c) *
                     (1.5707288f + c * (-0.2121144f + c * (0.0742610f + c * -0.0187293f)));
    const float t = detail::Min(th, max_theta);
    const float r = t / (half_pi - t);
    // [N] σ_L = 0.8 + 0.035·θ/(π/2 − θ) px (θ capped at 85°; beyond it is dropped).
    slp[p] = 0.8f + 0.035f * r * finite;
    // [N] σ_z = 0.0012 + 0.0019·(z − 0.4)² m for θ ≤ 60°, plus
    // (0.0001/√z)·θ²/(π/2 − θ)² beyond 60° (their Eq. for large angles).
    const float beyond60 = t > sixty ? 1.0f : 0.0f;
    const float sz = 0.0012f + 0.0019f * (z - 0.4f) * (z - 0.4f) +
                     beyond60 * 0.0001f / std::sqrt(z) * r * r;
    // [N] measured σ_z on real, quantised readings: when we quantise too, only the rest
    // is Gaussian (Sheppard: total variance ≈ σ_g² + ΔZ²/12, ΔZ = Z²·step/(b·f) [K]).
    const float dz = z * z * step / bfq;
    sgp[p] = std::sqrt(detail::Max(sz * sz - dz * dz * q12, 0.0f));
    // Grazing dropout probability: 0 below grazing_start, linear to 1 at grazing_full.
    pdp[p] = detail::Min(detail::Max((th - t0) * inv_ramp, 0.0f), 1.0f);
  }
}

}  // namespace detail

void KinectOptions::Validate() const {
  if (intrinsics.width <= 0 || intrinsics.height <= 0 || intrinsics.width > 16384 ||
      intrinsics.height > 16384)
    throw Error("kinect.intrinsics: width and height must be in 1..16384");
  if (!(intrinsics.fx > 0) || !(intrinsics.fy > 0))
    throw Error("kinect.intrinsics: fx and fy must be > 0");
  if (!std::isfinite(intrinsics.cx) || !std::isfinite(intrinsics.cy))
    throw Error("kinect.intrinsics: cx and cy must be finite");
  if (!(min_range > 0)) throw Error("kinect.min_range: must be > 0");
  if (!(max_range > min_range) || !std::isfinite(max_range))
    throw Error("kinect.max_range: must be finite and > min_range");
  if (!(baseline > 0)) throw Error("kinect.baseline: must be > 0");
  if (!(disparity_focal > 0)) throw Error("kinect.disparity_focal: must be > 0");
  if (!(disparity_subpixel > 0 && disparity_subpixel <= 1))
    throw Error("kinect.disparity_subpixel: must be in (0, 1]");
  if (!(grazing_start_deg > 0 && grazing_start_deg <= grazing_full_deg &&
        grazing_full_deg <= 90))
    throw Error("kinect.grazing_start_deg/grazing_full_deg: need 0 < start <= full <= 90");
  if (!(edge_jump > 0)) throw Error("kinect.edge_jump: must be > 0");
  if (!(edge_dropout_probability >= 0 && edge_dropout_probability <= 1))
    throw Error("kinect.edge_dropout_probability: must be in [0, 1]");
}

std::vector<float> ApplyKinectNoise(const ExactFrame& exact, const KinectOptions& o, Rng& rng) {
  const int W = o.intrinsics.width, H = o.intrinsics.height;
  const size_t n = size_t(W) * H;
  DRAPE_CHECK(exact.depth.size() == n && exact.cos_incidence.size() == n,
              "exact frame size does not match the intrinsics");
  const float zmin = float(o.min_range), zmax = float(o.max_range);
  std::vector<float> out(n, 0.0f);
  const std::vector<float>& Z = exact.depth;
  if (!o.noise) {
    for (size_t p = 0; p < n; ++p)
      out[p] = (Z[p] >= zmin && Z[p] <= zmax) ? Z[p] : 0.0f;
    return out;
  }
  const auto& N = NormalTable();

  // 1. Per-pixel noise parameters from the exact image: no randomness, branch-free
  //    float loops (vectorised; this file is built with -O3 -fno-math-errno).
  const float* C = exact.cos_incidence.data();
  const float half_pi = float(M_PI / 2), max_theta = float(85 * M_PI / 180);
  const float sixty = float(M_PI / 3);
  const float t0 = float(o.grazing_start_deg * M_PI / 180),
              t1 = float(o.grazing_full_deg * M_PI / 180);
  const float bfq = float(o.baseline * o.disparity_focal);  // m·px, [K]
  const float step = float(o.disparity_subpixel);           // px
  // Loop invariants as factors, so that the loop below has no control flow.
  const float q12 = o.quantize ? 1.0f / 12.0f : 0.0f;
  const float inv_ramp = t1 > t0 ? 1.0f / (t1 - t0) : 1e30f;
  const float big = zmax * 4;  // farther (and +inf = nothing hit) counts as no surface
  std::vector<float> sg(n), sl(n), pdrop(n);
  detail::NoiseParameters(Z.data(), C, sg.data(), sl.data(), pdrop.data(), n, big, max_theta, half_pi, sixty,
                  step, bfq, q12, t0, inv_ramp);
  if (!o.dropouts) std::fill(pdrop.begin(), pdrop.end(), 0.0f);

  // Projector shadow (deterministic): which source pixels the pattern reaches.
  std::vector<uint8_t> lit(n);
  for (size_t p = 0; p < n; ++p) lit[p] = Z[p] <= zmax * 4 ? 1 : 0;
  if (o.dropouts && o.projector_shadow) {
    // Projector at +baseline along camera x (Kinect v1: projector at the camera's right,
    // so shadows fall on the left of near objects). A point at column u and depth z is
    // lit at projector column u − b·f/z; scanning towards the projector, it is in shadow
    // if a point between it and the projector is lit at a smaller projector column.
    const float bf = float(o.baseline * o.intrinsics.fx);
    for (int v = 0; v < H; ++v) {
      float m = std::numeric_limits<float>::infinity();
      for (int u = W - 1; u >= 0; --u) {
        const size_t p = size_t(v) * W + u;
        if (!lit[p]) continue;
        const float up = float(u) - bf / Z[p];
        if (up > m + 0.25f) lit[p] = 0;
        m = std::min(m, up);
      }
    }
  }
  if (o.dropouts && o.edge_dropout_probability > 0) {
    // Depth edge: a 4-neighbour differs by more than edge_jump (or has no surface).
    const float jump = float(o.edge_jump), pe = float(o.edge_dropout_probability);
    // jr[p]: jump between p and its right neighbour; jd[p]: between p and the one below.
    std::vector<uint8_t> jr(n, 0), jd(n, 0), edge(n, 0);
    for (size_t p = 0; p + 1 < n; ++p) jr[p] = !(std::abs(Z[p + 1] - Z[p]) <= jump);
    for (size_t p = 0; p + W < n; ++p) jd[p] = !(std::abs(Z[p + W] - Z[p]) <= jump);
    for (int v = 0; v < H; ++v) jr[size_t(v) * W + W - 1] = 0;  // no wrap-around
    edge[0] = jr[0] | jd[0];
    for (size_t p = 1; p < n; ++p) edge[p] = jr[p] | jr[p - 1] | jd[p];
    for (size_t p = W; p < n; ++p) edge[p] |= jd[p - W];
    for (size_t p = 0; p < n; ++p)
      pdrop[p] = edge[p] ? 1.0f - (1.0f - pdrop[p]) * (1.0f - pe) : pdrop[p];
  }

  // 2. Per source pixel (raster order, one 64-bit draw each): random dropouts, axial
  //    noise, quantisation, range cut → measured[p]; and the lateral offset of pixel p.
  std::vector<float> measured(n, 0.0f);
  std::vector<int8_t> offset(o.lateral ? 2 * n : 0);
  for (size_t p = 0; p < n; ++p) {
    const uint64_t b = rng.NextU64();
    if (o.lateral) {
      // Round to nearest without a libm call (+64 keeps the argument positive).
      offset[2 * p] = int8_t(int(sl[p] * N[b & 0xFFFF] + 64.5f) - 64);
      offset[2 * p + 1] = int8_t(int(sl[p] * N[(b >> 16) & 0xFFFF] + 64.5f) - 64);
    }
    if (!lit[p]) continue;
    const float uni = (float((b >> 48) & 0xFFFF) + 0.5f) * (1.0f / 65536.0f);
    if (uni < pdrop[p]) continue;
    float z = Z[p];
    if (o.axial) z += sg[p] * N[(b >> 32) & 0xFFFF];
    if (o.quantize && z > 0) {
      // [K] disparity d = b·f/Z, quantised to 1/8 px (round half up; d > 0).
      const float d = float(int(bfq / (z * step) + 0.5f)) * step;
      z = d > 0 ? bfq / d : 0.0f;
    }
    if (z >= zmin && z <= zmax) measured[p] = z;
  }

  // 3. Lateral noise: pixel p reports the measurement of pixel p + offset.
  if (!o.lateral) return measured;
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t p = size_t(v) * W + u;
      const int uu = u + offset[2 * p], vv = v + offset[2 * p + 1];
      if (uu < 0 || uu >= W || vv < 0 || vv >= H) continue;
      out[p] = measured[size_t(vv) * W + uu];
    }
  }
  return out;
}

}  // namespace drape
