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
//  1. dropouts on the exact image (shadow, grazing, edges) mark source pixels invalid;
//  2. lateral noise: pixel p reads source pixel p + round(σ_L·n) (n ~ N(0, 1) per axis);
//  3. axial Gaussian noise, then disparity quantisation, then the range cut.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "generator/sweep/sweep.h"

namespace drape {
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

constexpr int kAngleBins = 4096;

}  // namespace

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
  std::vector<uint64_t> bits(n);
  for (size_t p = 0; p < n; ++p) bits[p] = rng.NextU64();

  // Incidence angle θ per pixel from its cosine, through a table (acos per pixel is the
  // single most expensive operation otherwise).
  std::array<float, kAngleBins + 1> acos_table;
  for (int i = 0; i <= kAngleBins; ++i) acos_table[i] = float(std::acos(double(i) / kAngleBins));
  std::vector<float> theta(n, 0.0f);
  for (size_t p = 0; p < n; ++p)
    if (std::isfinite(Z[p]))
      theta[p] = acos_table[int(std::clamp(exact.cos_incidence[p], 0.0f, 1.0f) * kAngleBins + 0.5f)];

  // 1. Dropouts: which source pixels return data.
  std::vector<uint8_t> ok(n);
  for (size_t p = 0; p < n; ++p) ok[p] = std::isfinite(Z[p]) ? 1 : 0;
  if (o.dropouts) {
    if (o.projector_shadow) {
      // Projector at +baseline along camera x (Kinect v1: projector at the camera's right,
      // so shadows fall on the left of near objects). A point at column u and depth z is
      // lit at projector column u − b·f/z; scanning towards the projector, it is in shadow
      // if a point between it and the projector is lit at a smaller projector column.
      const double bf = o.baseline * o.intrinsics.fx;
      for (int v = 0; v < H; ++v) {
        double m = std::numeric_limits<double>::infinity();
        for (int u = W - 1; u >= 0; --u) {
          const size_t p = size_t(v) * W + u;
          if (!ok[p]) continue;
          const double up = u - bf / Z[p];
          if (up > m + 0.25) ok[p] = 0;
          m = std::min(m, up);
        }
      }
    }
    const float t0 = float(o.grazing_start_deg * M_PI / 180),
                t1 = float(o.grazing_full_deg * M_PI / 180);
    const float jump = float(o.edge_jump), pe = float(o.edge_dropout_probability);
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const size_t p = size_t(v) * W + u;
        if (!ok[p]) continue;
        float pg = 0.0f;
        if (theta[p] >= t1) {
          pg = 1.0f;
        } else if (theta[p] > t0) {
          pg = (theta[p] - t0) / (t1 - t0);
        }
        // Depth edge: a 4-neighbour differs by more than edge_jump (or has no surface).
        const float z = Z[p];
        bool edge = false;
        if (u > 0) edge |= !(std::abs(Z[p - 1] - z) <= jump);
        if (u + 1 < W) edge |= !(std::abs(Z[p + 1] - z) <= jump);
        if (v > 0) edge |= !(std::abs(Z[p - W] - z) <= jump);
        if (v + 1 < H) edge |= !(std::abs(Z[p + W] - z) <= jump);
        const float pdrop = 1.0f - (1.0f - pg) * (1.0f - (edge ? pe : 0.0f));
        const float uni = (float((bits[p] >> 48) & 0xFFFF) + 0.5f) / 65536.0f;
        if (uni < pdrop) ok[p] = 0;
      }
    }
  }

  // 2.–3. Lateral resampling, axial noise, quantisation, range cut.
  const double bfq = o.baseline * o.disparity_focal;  // m·px, [K]
  const double step = o.disparity_subpixel;           // px
  const float half_pi = float(M_PI / 2), max_theta = float(85 * M_PI / 180);
  const float sixty = float(M_PI / 3);
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t p = size_t(v) * W + u;
      const uint64_t b = bits[p];
      size_t q = p;
      if (o.lateral) {
        // [N] σ_L = 0.8 + 0.035·θ/(π/2 − θ) px (θ capped at 85°, beyond it is dropped).
        float sl = 0.8f;
        if (std::isfinite(Z[p])) {
          const float t = std::min(theta[p], max_theta);
          sl += 0.035f * t / (half_pi - t);
        }
        const int du = int(std::lrint(sl * N[b & 0xFFFF]));
        const int dv = int(std::lrint(sl * N[(b >> 16) & 0xFFFF]));
        const int uu = u + du, vv = v + dv;
        if (uu < 0 || uu >= W || vv < 0 || vv >= H) continue;
        q = size_t(vv) * W + uu;
      }
      if (!ok[q]) continue;
      double z = Z[q];
      const double dz_step = z * z * step / bfq;  // [K] depth step at z
      if (o.axial) {
        // [N] σ_z = 0.0012 + 0.0019·(z − 0.4)² m for θ ≤ 60°, plus
        // (0.0001/√z)·θ²/(π/2 − θ)² beyond 60° (their Eq. for large angles).
        double sz = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
        const float t = std::min(theta[q], max_theta);
        if (t > sixty) sz += 0.0001 / std::sqrt(z) * double(t) * t / ((half_pi - t) * (half_pi - t));
        // [N] measured σ_z on real, quantised readings: when we quantise too, only the
        // rest is Gaussian (Sheppard: total variance ≈ σ_g² + ΔZ²/12).
        double sg = sz;
        if (o.quantize) sg = std::sqrt(std::max(sz * sz - dz_step * dz_step / 12, 0.0));
        z += sg * N[(b >> 32) & 0xFFFF];
      }
      if (o.quantize && z > 0) {
        // [K] disparity d = b·f/Z, quantised to 1/8 px.
        const double d = std::nearbyint(bfq / z / step) * step;
        z = d > 0 ? bfq / d : 0.0;
      }
      if (z >= zmin && z <= zmax) out[p] = float(z);
    }
  }
  return out;
}

}  // namespace drape
