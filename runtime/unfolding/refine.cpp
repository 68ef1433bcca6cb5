#include "runtime/unfolding/refine.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"

namespace drape::unfolding {

void RefineOptions::Validate() const {
  if (!(sigma_samples >= 0.5 && sigma_samples <= 1000)) throw Error("refine.sigma_samples: must be in [0.5, 1000]");
  if (!(sample_spacing > 0 && sample_spacing < 1)) throw Error("refine.sample_spacing: must be in (0, 1) m");
  if (half_width_samples < 1 || half_width_samples > 100000)
    throw Error("refine.half_width_samples: must be in 1..100000");
  if (search_half_width_samples < 0 || search_half_width_samples > half_width_samples)
    throw Error("refine.search_half_width_samples: must be in 0..half_width_samples");
  if (depth_half_width_samples < 0 || depth_half_width_samples > half_width_samples)
    throw Error("refine.depth_half_width_samples: must be in 0..half_width_samples");
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
  if (at_jaw_line) p -= c * mount.x() + a.cross(c) * mount.y();
  return p;
}

Vec3 IrScanPlan::Grasp(const RefineResult& r) const {
  const Vec3& a = approach;
  const Vec3& c = closing;
  // Grouped as the first build computed it (--ir-above-jaws: the same rounding).
  const Vec3 base = predicted - a * standoff;
  return base + c * r.offset + a * (r.range + mount.z() + grasp_depth);
}

}  // namespace drape::unfolding

namespace drape::unfolding {

Vec3 IrScanPlan::JawDuringScan(double offset, double up) const {
  return JawDuringScan(offset) + approach.cross(closing) * up;
}

Vec3 IrScanPlan::Grasp(double offset, double up, double range) const {
  const Vec3& a = approach;
  const Vec3& c = closing;
  const Vec3 base = predicted - a * standoff;
  return base + c * offset + a.cross(c) * up + a * (range + mount.z() + grasp_depth);
}

void EdgeOptions::Validate() const {
  if (!(sample_spacing > 0 && sample_spacing < 1)) throw Error("edge.sample_spacing: must be in (0, 1) m");
  if (above_samples < 0 || above_samples > 100000) throw Error("edge.above_samples: must be in 0..100000");
  if (below_samples < 1 || below_samples > 100000) throw Error("edge.below_samples: must be in 1..100000");
  if (!(near > 0)) throw Error("edge.near: must be > 0 m");
  if (!(jump > 0)) throw Error("edge.jump: must be > 0 m");
  if (!(inset >= 0)) throw Error("edge.inset: must be >= 0 m");
  if (!(radius > 0)) throw Error("edge.radius: must be > 0 m");
  if (!(below_margin >= 0)) throw Error("edge.below_margin: must be >= 0 m");
  if (!(below_fraction >= 0 && below_fraction <= 1)) throw Error("edge.below_fraction: must be in [0, 1]");
  if (!(side_inset >= 0)) throw Error("edge.side_inset: must be >= 0 m");
  if (!(side_radius > 0)) throw Error("edge.side_radius: must be > 0 m");
  if (!(side_margin > 0)) throw Error("edge.side_margin: must be > 0 m");
}

namespace {
// The contiguous surface samples of a scan through the sample nearest `centre` that reads
// within `near` of `reference` (ties: the lower index); consecutive readings within `jump`.
struct Run {
  int start = -1, lo = -1, hi = -1;
};
Run SurfaceRun(const std::vector<double>& ranges, int centre, double reference, double near, double jump,
               bool before = true) {
  const int n = static_cast<int>(ranges.size());
  auto ok = [&](int i) { return std::isfinite(ranges[i]) && ranges[i] > 0; };
  auto surface = [&](int i) { return ok(i) && std::abs(ranges[i] - reference) <= near; };
  auto joined = [&](int i, int j) { return ok(i) && ok(j) && std::abs(ranges[i] - ranges[j]) <= jump; };
  Run r;
  for (int d = 0; d < n && r.start < 0; ++d) {
    if (before && centre - d >= 0 && surface(centre - d)) {
      r.start = centre - d;
    } else if (centre + d < n && surface(centre + d)) {
      r.start = centre + d;
    }
  }
  if (r.start < 0) return r;
  r.lo = r.hi = r.start;
  while (r.hi + 1 < n && joined(r.hi, r.hi + 1)) ++r.hi;
  while (r.lo > 0 && joined(r.lo, r.lo - 1)) --r.lo;
  return r;
}
}  // namespace

EdgeResult FindLowerEdge(const std::vector<double>& ranges, double reference, const EdgeOptions& options) {
  options.Validate();
  const int n = static_cast<int>(ranges.size());
  if (n != options.above_samples + options.below_samples + 1)
    throw Error("edge: the vertical scan has " + std::to_string(n) + " readings, expected " +
                std::to_string(options.above_samples + options.below_samples + 1));
  // Top to bottom: the upper sample wins a tie for the nearest surface sample.
  const int centre = options.above_samples;
  const Run run = SurfaceRun(ranges, centre, reference, options.near, options.jump, options.look_above);
  EdgeResult r;
  r.start = run.start;
  if (run.start < 0 || run.hi == n - 1) return r;  // no surface, or it goes on below the scan
  r.found = true;
  r.edge = run.hi;
  r.grasp = std::max(run.lo, run.hi - static_cast<int>(std::lround(options.inset / options.sample_spacing)));
  r.up = (centre - r.grasp) * options.sample_spacing;
  r.range = ranges[r.grasp];
  return r;
}

SideResult FindSideEdge(const std::vector<double>& ranges, double reference, int toward, double spacing,
                        const EdgeOptions& options) {
  options.Validate();
  if (ranges.size() < 3 || ranges.size() % 2 == 0)
    throw Error("edge: a side scan needs an odd number (>= 3) of readings");
  if (toward != -1 && toward != 1) throw Error("edge: the side to look for must be -1 or +1");
  if (!(spacing > 0)) throw Error("edge: the side scan's spacing must be > 0 m");
  const int n = static_cast<int>(ranges.size()), centre = n / 2;
  const Run run = SurfaceRun(ranges, centre, reference, options.near, options.jump);
  SideResult r;
  r.start = run.start;
  if (run.start < 0) return r;
  const int inset = static_cast<int>(std::lround(options.side_inset / spacing));
  if (toward < 0) {
    if (run.lo == 0) return r;  // the surface goes on past the scan
    r.edge = run.lo;
    r.grasp = std::min(run.hi, run.lo + inset);
  } else {
    if (run.hi == n - 1) return r;
    r.edge = run.hi;
    r.grasp = std::max(run.lo, run.hi - inset);
  }
  r.found = true;
  r.offset = (r.grasp - centre) * spacing;
  r.range = ranges[r.grasp];
  return r;
}

int CornerSide(const TriMesh& mesh, int v, const Vec3& closing, const EdgeOptions& options) {
  options.Validate();
  DRAPE_CHECK(v >= 0 && v < mesh.NumVertices(), "anchor vertex out of range");
  const Vec3 p = mesh.V.row(v);
  double sum = 0;
  int around = 0;
  for (int i = 0; i < mesh.NumVertices(); ++i) {
    const Vec3 q = mesh.V.row(i);
    if (i == v || (q - p).norm() > options.side_radius) continue;
    sum += (q - p).dot(closing);
    ++around;
  }
  if (around == 0) return 0;
  const double mean = sum / around;
  return mean > options.side_margin ? -1 : mean < -options.side_margin ? 1 : 0;
}

bool AnchorAtLowerEdge(const TriMesh& mesh, int v, const EdgeOptions& options) {
  options.Validate();
  DRAPE_CHECK(v >= 0 && v < mesh.NumVertices(), "anchor vertex out of range");
  const Vec3 p = mesh.V.row(v);
  int around = 0, below = 0;
  for (int i = 0; i < mesh.NumVertices(); ++i) {
    if (i == v) continue;
    const Vec3 q = mesh.V.row(i);
    if ((q - p).norm() > options.radius) continue;
    ++around;
    if (q.y() < p.y() - options.below_margin) ++below;
  }
  return around > 0 && below <= options.below_fraction * around;
}

}  // namespace drape::unfolding
