#include "runtime/unfolding/refine.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/field_error.h"

namespace drape::unfolding {

void RefineOptions::Validate() const {
  if (!(sigma_samples >= 0.5 && sigma_samples <= 1000))
    BadField(sigma_samples, "RefineOptions.sigma_samples", "must be in [0.5, 1000]");
  if (!(sample_spacing > 0 && sample_spacing < 1))
    BadField(sample_spacing, "RefineOptions.sample_spacing", "must be in (0, 1) m");
  if (half_width_samples < 1 || half_width_samples > 100000)
    BadField(half_width_samples, "RefineOptions.half_width_samples", "must be in 1..100000");
  if (search_half_width_samples < 0 || search_half_width_samples > half_width_samples)
    BadField(search_half_width_samples, "RefineOptions.search_half_width_samples", "must be in 0..half_width_samples");
  if (depth_half_width_samples < 0 || depth_half_width_samples > half_width_samples)
    BadField(depth_half_width_samples, "RefineOptions.depth_half_width_samples", "must be in 0..half_width_samples");
}

std::vector<double> LaplacianOfGaussian(double sigma) {
  DRAPE_CHECK(sigma > 0, "sigma must be positive");
  const int r = static_cast<int>(std::ceil(4 * sigma));
  std::vector<double> k(2 * r + 1);
  const double s2 = sigma * sigma;
  for (int i = -r; i <= r; ++i) {
    const double x2 = double(i) * i;
    k[i + r] = (x2 / (s2 * s2) - 1 / s2) * std::exp(-x2 / (2 * s2));
  }
  return k;
}

std::vector<double> Convolve(const std::vector<double>& signal, const std::vector<double>& kernel) {
  const int n = static_cast<int>(signal.size()), m = static_cast<int>(kernel.size()), r = m / 2;
  std::vector<double> out(n, 0.0);
  if (n == 0) return out;
  for (int i = 0; i < n; ++i) {
    double s = 0;
    for (int k = 0; k < m; ++k) s += signal[std::clamp(i - k + r, 0, n - 1)] * kernel[k];
    out[i] = s;
  }
  return out;
}

RefineResult RefineScan(const std::vector<double>& ranges, const RefineOptions& options) {
  options.Validate();
  if (ranges.empty()) throw Error("refine: the IR scan has no readings");
  const int n = static_cast<int>(ranges.size());
  auto ok = [&](int i) { return std::isfinite(ranges[i]) && ranges[i] > 0; };
  RefineResult r;
  r.height.assign(n, 0.0);
  // Nearest valid reading for the missing ones (ties: the earlier sample).
  std::vector<int> src(n, -1);
  int last = -1;
  for (int i = 0; i < n; ++i) {
    if (ok(i)) last = i;
    src[i] = last;
  }
  last = -1;
  for (int i = n - 1; i >= 0; --i) {
    if (ok(i)) last = i;
    if (last >= 0 && (src[i] < 0 || last - i < i - src[i])) src[i] = last;
  }
  const double centre = 0.5 * (double(n) - 1);
  if (src[0] < 0) {  // nothing in range anywhere
    r.best = n / 2;
    r.offset = (r.best - centre) * options.sample_spacing;
    r.response.assign(n, 0.0);
    return r;
  }
  r.valid = true;
  for (int i = 0; i < n; ++i) r.height[i] = -ranges[src[i]];
  r.response = Convolve(r.height, LaplacianOfGaussian(options.sigma_samples));
  // Lowest local minimum within the search window (strictly below its left neighbour, not
  // above its right one, so a flat stretch counts once; the scan's ends are no minima: the
  // response there is shaped by the end extension). A window edge can be one.
  const int mid = n / 2;
  const int lo = std::max(1, mid - options.search_half_width_samples);
  const int hi = std::min(n - 2, mid + options.search_half_width_samples);
  r.best = mid;
  for (int i = lo; i <= hi; ++i) {
    const double v = r.response[i];
    if (v < r.response[i - 1] && v <= r.response[i + 1] && (!r.fold_found || v < r.response[r.best])) {
      r.best = i;
      r.fold_found = true;
    }
  }
  r.offset = (r.best - centre) * options.sample_spacing;
  r.range = -r.height[r.best];
  r.measured = ok(r.best);
  for (int i = std::max(0, r.best - options.depth_half_width_samples);
       i <= std::min(n - 1, r.best + options.depth_half_width_samples); ++i)
    if (ok(i) && (!r.measured || ranges[i] < r.range)) r.range = ranges[i], r.measured = true;
  return r;
}

Vec3 IrScanPlan::JawDuringScan(double offset) const {
  const Vec3& a = approach;
  const Vec3& c = closing;
  Vec3 p = predicted - a * standoff + c * offset;
  p -= c * mount.x() + a.cross(c) * mount.y();
  return p;
}

Vec3 IrScanPlan::Grasp(const RefineResult& r) const {
  const Vec3& a = approach;
  const Vec3& c = closing;
  const Vec3 base = predicted - a * standoff;
  return base + c * r.offset + a * (r.range + mount.z() + grasp_depth);
}

}  // namespace drape::unfolding
