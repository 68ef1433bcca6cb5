// TSDF integration, space carving and queries (no OpenVDB here: it lives in vdb.cpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "common/cpu_time.h"
#include "common/error.h"
#include "common/field_error.h"
#include "common/parallel.h"
#include "common/rng.h"
#include "common/timing.h"
#include "generator/fusion/fusion.h"
#include "generator/fusion/tsdf_impl.h"

namespace drape {

namespace {

template <typename T>
[[noreturn]] void Bad(const T& field, const std::string& name, const std::string& what) {
  BadField(field, "FusionOptions." + name, what);
}

void CheckFrame(const std::vector<float>& depth, const Intrinsics& K) {
  if (K.width <= 0 || K.height <= 0 || !(K.fx > 0) || !(K.fy > 0))
    throw Error("Intrinsics: width, height, fx, fy must be positive");
  if (depth.size() != size_t(K.width) * K.height) {
    std::ostringstream os;
    os << "DepthFrame.depth: " << depth.size() << " values, expected " << K.width << "x" << K.height;
    throw Error(os.str());
  }
}

// Seconds since t0; restarts t0.
double Lap(Clock::time_point& t0) {
  const auto now = Clock::now();
  const double s = Seconds(t0, now);
  t0 = now;
  return s;
}

// CPU seconds since c0; restarts c0.
double CpuLap(double& c0) {
  const double now = ProcessCpuSeconds();
  const double s = now - c0;
  c0 = now;
  return s;
}

}  // namespace

void FusionOptions::Validate() const {
  if (!(voxels_per_metre >= 10 && voxels_per_metre <= 4096))
    Bad(voxels_per_metre, "voxels_per_metre", "must be in [10, 4096]");
  if (!(truncation >= 0 && truncation <= 1)) Bad(truncation, "truncation", "must be in [0, 1] m (0 = 4 voxels)");
  if (truncation > 0 && truncation < 1.0 / voxels_per_metre)
    Bad(truncation, "truncation", "must be at least one voxel");
  if (truncation > 16.0 / voxels_per_metre)
    Bad(truncation, "truncation", "must be at most 16 voxels (2 blocks), the band is allocated in 8³ blocks");
  if (box.isEmpty() || !box.min().allFinite() || !box.max().allFinite())
    Bad(box, "box", "must be a non-empty finite box");
  if ((box.sizes().array() * voxels_per_metre / kBlockDim).prod() > 2e7)
    Bad(box, "box", "too large for the carving grid at this voxel size");
  if (!std::isfinite(radius)) Bad(radius, "radius", "must be finite (<= 0: no radial limit)");
  if (min_weight < 1) Bad(min_weight, "min_weight", "must be >= 1");
  if (carve_min_views < 1 || carve_min_views > 100000) Bad(carve_min_views, "carve_min_views", "must be in 1..100000");
  if (!(carve_min_fraction >= 0 && carve_min_fraction <= 1))
    Bad(carve_min_fraction, "carve_min_fraction", "must be in [0, 1]");
  if (hole_radius_px < 0 || hole_radius_px > 64) Bad(hole_radius_px, "hole_radius_px", "must be in [0, 64]");
  if (frames_stride < 1 || frames_stride > 100000) Bad(frames_stride, "frames_stride", "must be in 1..100000");
  if (!(pose_noise_degrees >= 0 && pose_noise_degrees <= 45))
    Bad(pose_noise_degrees, "pose_noise_degrees", "must be in [0, 45]");
}

Tsdf::Tsdf(const FusionOptions& options) : impl_(std::make_unique<Impl>()) {
  options.Validate();
  Impl& m = *impl_;
  m.opt = options;
  m.h = options.VoxelSize();
  m.mu = options.Truncation();
  // Carving grid: every block that overlaps the box.
  Eigen::Vector3i lo, hi;
  for (int a = 0; a < 3; ++a) {
    lo[a] = FloorDiv8(static_cast<int>(std::floor(options.box.min()[a] / m.h)));
    hi[a] = FloorDiv8(static_cast<int>(std::ceil(options.box.max()[a] / m.h)));
  }
  m.carve_lo = lo;
  m.carve_dims = hi - lo + Eigen::Vector3i::Ones();
  const size_t cells = size_t(m.carve_dims.x()) * m.carve_dims.y() * m.carve_dims.z();
  m.free_count.assign(cells, 0);
  m.view_count.assign(cells, 0);
  m.grid_lo = lo - Eigen::Vector3i::Constant(Impl::kGridMargin);
  m.grid_dims = m.carve_dims + Eigen::Vector3i::Constant(2 * Impl::kGridMargin);
  m.grid.assign(size_t(m.grid_dims.x()) * m.grid_dims.y() * m.grid_dims.z(), -1);
}

Tsdf::~Tsdf() = default;

const FusionOptions& Tsdf::options() const { return impl_->opt; }

void Tsdf::Integrate(const DepthFrame& frame, const Intrinsics& K) {
  CheckFrame(frame.depth, K);
  impl_->IntegrateBatch({{frame.depth.data(), frame.camera_to_object}}, K);
}

void Tsdf::IntegrateReference(const DepthFrame& frame, const Intrinsics& K) {
  CheckFrame(frame.depth, K);
  impl_->IntegrateReference(frame.depth, frame.camera_to_object, K);
}

void Tsdf::Impl::UpdateRays(const Intrinsics& K) {
  if (rays_valid && rays_for.width == K.width && rays_for.height == K.height && rays_for.fx == K.fx &&
      rays_for.fy == K.fy && rays_for.cx == K.cx && rays_for.cy == K.cy)
    return;
  xhat.resize(K.width);
  yhat.resize(K.height);
  for (int u = 0; u < K.width; ++u) xhat[u] = (u - K.cx) / K.fx;
  for (int v = 0; v < K.height; ++v) yhat[v] = (v - K.cy) / K.fy;
  rays_for = K;
  rays_valid = true;
}

// The region that can matter in the object frame: foreground points lie in the box
// (and within the radius of the axis); the band allocates blocks containing points
// within μ of them, whose voxels lie within μ + 7.5 voxels (L∞) of them; a carving
// cell can only end up inside if it lies within the bounds of those blocks. So the
// voxels read and the cells counted lie within the box ∩ cylinder grown by μ + 9 h,
// their block centres within a further block: project that box to get the pixels.
FrameView Tsdf::Impl::MakeView(const Eigen::Isometry3d& pose, const Intrinsics& K) const {
  FrameView view;
  view.W = K.width, view.H = K.height, view.K = K;
  view.R = pose.linear();
  view.Rt = view.R.transpose();
  view.t = pose.translation();
  Vec3 lo = opt.box.min(), hi = opt.box.max();
  if (opt.radius > 0) {
    for (int a : {0, 2}) lo[a] = std::max(lo[a], -opt.radius), hi[a] = std::min(hi[a], opt.radius);
  }
  lo.array() -= mu + 9 * h;
  hi.array() += mu + 9 * h;
  for (int a = 0; a < 3; ++a) {
    const int b_lo = FloorDiv8(static_cast<int>(std::floor(lo[a] / h))) - carve_lo[a];
    const int b_hi = FloorDiv8(static_cast<int>(std::ceil(hi[a] / h))) - carve_lo[a];
    view.cell_lo[a] = std::max(0, b_lo);
    view.cell_hi[a] = std::min(carve_dims[a] - 1, b_hi);
  }
  lo.array() -= kBlockDim * h;
  hi.array() += kBlockDim * h;
  double umin = 1e30, umax = -1e30, vmin = 1e30, vmax = -1e30;
  bool behind = false;
  for (int c = 0; c < 8; ++c) {
    const Vec3 p((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
    const Vec3 q = view.Rt * (p - view.t);
    if (q.z() <= 1e-3) {
      behind = true;
      break;
    }
    const double u = K.fx * q.x() / q.z() + K.cx, v = K.fy * q.y() / q.z() + K.cy;
    umin = std::min(umin, u), umax = std::max(umax, u), vmin = std::min(vmin, v), vmax = std::max(vmax, v);
  }
  if (behind) {
    view.u0 = view.v0 = 0, view.u1 = view.W, view.v1 = view.H;
    return view;
  }
  // Two pixels of slack for rounding (voxels round to the nearest pixel in floats).
  auto clampi = [](double x, int hi_) { return static_cast<int>(std::clamp(x, 0.0, double(hi_))); };
  view.u0 = clampi(std::floor(umin) - 2, view.W), view.u1 = clampi(std::ceil(umax) + 3, view.W);
  view.v0 = clampi(std::floor(vmin) - 2, view.H), view.v1 = clampi(std::ceil(vmax) + 3, view.H);
  return view;
}

int Tsdf::Impl::FindOrCreateBlock(const Eigen::Vector3i& b) {
  const int64_t g = GridIndex(b);
  if (g >= 0 && grid[g] >= 0) return grid[g];
  auto [it, inserted] = index.try_emplace(Key(b), static_cast<int>(blocks.size()));
  if (inserted) {
    auto blk = std::make_unique<FusionBlock>();
    blk->coord = b;
    blk->tsdf.fill(0.f);
    blk->weight.fill(0.f);
    blocks.push_back(std::move(blk));
    if (g >= 0) grid[g] = it->second;
  }
  return it->second;
}

// Frames of a batch whose frame-local steps run at once (their buffers are kept: ~2 MB
// per frame at 640×480).
constexpr int kBatchFrames = 8;

void Tsdf::Impl::IntegrateBatch(const std::vector<FrameInput>& inputs, const Intrinsics& K) {
  UpdateRays(K);
  for (size_t first = 0; first < inputs.size(); first += kBatchFrames) {
    const size_t n = std::min(inputs.size() - first, size_t(kBatchFrames));
    while (prepared.size() < n) prepared.push_back(std::make_unique<PreparedFrame>());
    std::vector<PreparedFrame*> batch(n);
    for (size_t i = 0; i < n; ++i) batch[i] = prepared[i].get();
    // 1. Frame-local steps, frames in parallel.
    auto t0 = Clock::now();
    double c0 = ProcessCpuSeconds();
    ParallelFor(static_cast<int>(n), opt.threads,
                [&](int i) { Prepare(inputs[first + i].depth, inputs[first + i].camera_to_object, K, *batch[i]); });
    {
      // Wall and process CPU of the phase, shared out by the threads' CPU per step.
      const double wall = Lap(t0), cpu = CpuLap(c0);
      double seg = 0, drop = 0, band = 0;
      for (const PreparedFrame* f : batch) seg += f->cpu_segment, drop += f->cpu_dropouts, band += f->cpu_band;
      const double sum = std::max(seg + drop + band, 1e-12);
      times.segment += wall * seg / sum, times_cpu.segment += cpu * seg / sum;
      times.dropouts += wall * drop / sum, times_cpu.dropouts += cpu * drop / sum;
      times.allocate += wall * band / sum, times_cpu.allocate += cpu * band / sum;
    }
    // 2. The band's blocks allocated in frame order (block indices as frame by frame).
    for (PreparedFrame* f : batch) {
      f->touched.resize(f->band.size());
      for (size_t k = 0; k < f->band.size(); ++k) f->touched[k] = FindOrCreateBlock(f->band[k]);
      foreground_pixels += f->fg_count;
    }
    times.allocate += Lap(t0), times_cpu.allocate += CpuLap(c0);
    // 3. Voxels, block by block over the batch's frames.
    UpdateVoxels(batch);
    times.update += Lap(t0), times_cpu.update += CpuLap(c0);
    // 4. Carving, cell by cell over the batch's frames.
    CarveBlocks(batch);
    times.carve += Lap(t0), times_cpu.carve += CpuLap(c0);
    frames += static_cast<int>(n);
    dirty.store(true);
  }
}

void Tsdf::Impl::Prepare(const float* depth, const Eigen::Isometry3d& pose, const Intrinsics& K,
                         PreparedFrame& f) const {
  double c0 = ThreadCpuSeconds();
  f.view = MakeView(pose, K);
  f.fg_count = Segment(depth, f.view, f.scratch);
  double c1 = ThreadCpuSeconds();
  f.cpu_segment = c1 - c0;
  if (f.fg_count > 0) IgnoreDropouts(f.view, f.scratch);
  c0 = ThreadCpuSeconds();
  f.cpu_dropouts = c0 - c1;
  BandBlocks(f.view, f.scratch, f.band);
  f.cpu_band = ThreadCpuSeconds() - c0;
}

// 1. Segmentation of the frame's rectangle into s.code / s.fg, row by row.
int64_t Tsdf::Impl::Segment(const float* depth, const FrameView& view, FrameScratch& s) const {
  static const auto segment_row = HaveAvx512VlBw() ? SegmentRowAvx512 : HaveAvx2() ? SegmentRowAvx2 : SegmentRowScalar;
  const int W = view.W;
  s.code.resize(size_t(W) * view.H);
  s.fg.resize(size_t(W) * view.H);
  SegmentRow row;
  row.xhat = xhat.data();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) row.R[i][j] = view.R(i, j);
    row.t[i] = view.t[i], row.lo[i] = opt.box.min()[i], row.hi[i] = opt.box.max()[i];
  }
  row.radius2 = opt.radius > 0 ? opt.radius * opt.radius : 0;
  int64_t fg_count = 0;
  s.far = 0;
  row.fg_lo = view.u1, row.fg_hi = view.u0;
  s.fg_v0 = view.v1, s.fg_v1 = view.v0;
  for (int v = view.v0; v < view.v1; ++v) {
    row.depth = depth + size_t(v) * W;
    row.code = s.code.data() + size_t(v) * W;
    row.fg = s.fg.data() + size_t(v) * W;
    row.yv = yhat[v];
    const int64_t n = segment_row(row, view.u0, view.u1, &s.far);
    if (n > 0) s.fg_v0 = std::min(s.fg_v0, v), s.fg_v1 = v + 1;
    fg_count += n;
  }
  s.fg_u0 = row.fg_lo, s.fg_u1 = row.fg_hi;
  return fg_count;
}

namespace {

int FindRoot(std::vector<int>& parent, int a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

}  // namespace

// 2. Pixels without data that the foreground encloses (not connected to the image
// border through non-foreground pixels) are dropouts on the garment (grazing angles,
// folds), not background → ignored (NaN); without this, dropouts carve the unobserved
// interior over a long sweep. So are pixels without data within hole_radius_px of a
// foreground pixel. Within the foreground's bounding rectangle only (Segment): no
// pixel outside it is foreground, so every pixel outside it reaches the image border
// straight along its row or column, and so does every non-foreground pixel on its
// edge. Connectivity by union–find over the rows' runs of non-foreground pixels
// (4-neighbours).
void Tsdf::Impl::IgnoreDropouts(const FrameView& view, FrameScratch& s) const {
  const int W = view.W;
  std::vector<int>& runs = s.runs;  // (row, u_begin, u_end) triples
  runs.clear();
  std::vector<int>& parent = s.parent;
  parent.clear();
  std::vector<uint8_t>& edge = s.edge;  // run touches the bounding rectangle's edge
  edge.clear();
  int prev_begin = 0;  // first run of the previous row
  const int u0 = s.fg_u0, u1 = s.fg_u1, v0 = s.fg_v0, v1 = s.fg_v1;
  for (int v = v0; v < v1; ++v) {
    const int row_begin = static_cast<int>(parent.size());
    const uint8_t* fg = &s.fg[size_t(v) * W];
    int q = prev_begin;  // runs of the previous row, scanned left to right
    for (int u = u0; u < u1;) {
      if (fg[u]) {
        ++u;
        continue;
      }
      int e = u;
      while (e < u1 && !fg[e]) ++e;
      const int id = static_cast<int>(parent.size());
      parent.push_back(id);
      runs.insert(runs.end(), {v, u, e});
      edge.push_back(v == v0 || v == v1 - 1 || u == u0 || e == u1);
      // Overlapping runs of the previous row: [b, c) ∩ [u, e) ≠ ∅.
      while (q < row_begin && runs[3 * q + 2] <= u) ++q;
      for (int k = q; k < row_begin && runs[3 * k + 1] < e; ++k) {
        const int a = FindRoot(parent, id), b = FindRoot(parent, k);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
      }
      u = e;
    }
    prev_begin = row_begin;
  }
  const int n = static_cast<int>(parent.size());
  std::vector<uint8_t>& reaches = s.reaches;
  reaches.assign(n, 0);
  for (int k = 0; k < n; ++k) reaches[FindRoot(parent, k)] |= edge[k];
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < n; ++k) {
    if (reaches[FindRoot(parent, k)]) continue;
    const size_t run = 3 * size_t(k);
    float* row = &s.code[size_t(runs[run]) * W];
    for (int u = runs[run + 1]; u < runs[run + 2]; ++u)
      if (row[u] == 0) row[u] = nan;
  }
  MarkNearForeground(view, s);
}

// Pixels without data within hole_radius_px (Chebyshev) of a foreground pixel → NaN:
// the foreground dilated by a (2r+1)² square, on bit masks (64 pixels a word): each
// row's foreground bits dilated by r along the row (r shifts by one), then the OR of the
// 2r + 1 rows around each row, then the no-data pixels under it set to NaN.
void Tsdf::Impl::MarkNearForeground(const FrameView& view, FrameScratch& s) const {
  static const bool avx512 = HaveAvx512VlBw();
  const int W = view.W, r = opt.hole_radius_px;
  // Only pixels within r of the foreground's bounding rectangle can be near it.
  const int u0 = std::max(view.u0, s.fg_u0 - r), u1 = std::min(view.u1, s.fg_u1 + r);
  const int v0 = std::max(view.v0, s.fg_v0 - r), v1 = std::min(view.v1, s.fg_v1 + r);
  const int w = u1 - u0, hgt = v1 - v0;
  if (w <= 0 || hgt <= 0) return;
  const int words = (w + 63) / 64;
  const uint64_t last = w % 64 ? (uint64_t(1) << (w % 64)) - 1 : ~uint64_t(0);  // the last word's pixels
  s.near_bits.resize(size_t(words) * hgt);
  s.row_bits.resize(words);
  for (int v = 0; v < hgt; ++v) {
    uint64_t* near = &s.near_bits[size_t(v) * words];
    (avx512 ? PackRowBitsAvx512 : PackRowBitsScalar)(&s.fg[size_t(v + v0) * W + u0], w, near);
    for (int step = 0; step < r; ++step) {
      uint64_t carry = 0;  // bit 63 of the previous word
      for (int k = 0; k < words; ++k) {
        const uint64_t b = near[k], next = k + 1 < words ? near[k + 1] : 0;
        s.row_bits[k] = b | (b << 1) | carry | (b >> 1) | (next << 63);
        carry = b >> 63;
      }
      for (int k = 0; k < words; ++k) near[k] = s.row_bits[k];
      near[words - 1] &= last;
    }
  }
  for (int v = 0; v < hgt; ++v) {
    for (int k = 0; k < words; ++k) s.row_bits[k] = 0;
    for (int q = std::max(0, v - r); q <= std::min(hgt - 1, v + r); ++q) {
      const uint64_t* near = &s.near_bits[size_t(q) * words];
      for (int k = 0; k < words; ++k) s.row_bits[k] |= near[k];
    }
    (avx512 ? NanWhereNoDataAvx512 : NanWhereNoDataScalar)(s.row_bits.data(), w, &s.code[size_t(v + v0) * W + u0]);
  }
}

void PackRowBitsScalar(const uint8_t* fg, int w, uint64_t* bits) {
  for (int k = 0; k < (w + 63) / 64; ++k) bits[k] = 0;
  for (int u = 0; u < w; ++u) bits[u >> 6] |= uint64_t(fg[u] != 0) << (u & 63);
}

void NanWhereNoDataScalar(const uint64_t* bits, int w, float* code) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < (w + 63) / 64; ++k) {
    for (uint64_t m = bits[k]; m; m &= m - 1) {
      const int u = 64 * k + __builtin_ctzll(m);
      if (u < w && code[u] == 0) code[u] = nan;
    }
  }
}

#if defined(__x86_64__)
__attribute__((target("avx512f,avx512vl,avx512bw"))) void PackRowBitsAvx512(const uint8_t* fg, int w, uint64_t* bits) {
  for (int k = 0; 64 * k < w; ++k) {
    const int left = w - 64 * k;
    const __mmask64 lanes = left >= 64 ? ~__mmask64(0) : (__mmask64(1) << left) - 1;
    const __m512i bytes = _mm512_maskz_loadu_epi8(lanes, fg + 64 * ptrdiff_t(k));
    bits[k] = _mm512_test_epi8_mask(bytes, bytes);
  }
}

__attribute__((target("avx512f,avx512vl,avx512bw"))) void NanWhereNoDataAvx512(const uint64_t* bits, int w,
                                                                               float* code) {
  const __m512 nan = _mm512_set1_ps(std::numeric_limits<float>::quiet_NaN()), zero = _mm512_setzero_ps();
  for (int u = 0; u < w; u += 16) {
    __mmask16 near = __mmask16(bits[u >> 6] >> (u & 63));
    if (!near) continue;
    if (w - u < 16) near &= __mmask16((1u << (w - u)) - 1);
    const __m512 c = _mm512_maskz_loadu_ps(near, code + u);
    _mm512_mask_storeu_ps(code + u, near & _mm512_cmp_ps_mask(c, zero, _CMP_EQ_OQ), nan);
  }
}
#else
void PackRowBitsAvx512(const uint8_t* fg, int w, uint64_t* bits) { PackRowBitsScalar(fg, w, bits); }
void NanWhereNoDataAvx512(const uint64_t* bits, int w, float* code) { NanWhereNoDataScalar(bits, w, code); }
#endif

// 3. The blocks that the band [d - μ, d + μ] of each foreground pixel crosses.
// Samples every half block along the ray, and every `stride` pixels with stride ≤ a
// third of a block's footprint at the farthest foreground depth, so no block the band
// crosses is skipped between samples. Each block listed once, at its first sample.
// A row's samples are rounded to blocks 8 pixels at a time (BandSamples*), then listed
// in order (pixel by pixel, along each ray).
void Tsdf::Impl::BandBlocks(const FrameView& view, FrameScratch& s, std::vector<Eigen::Vector3i>& band) const {
  static const auto samples_kernel = HaveAvx512VlBw() ? BandSamplesAvx512 : BandSamplesScalar;
  band.clear();
  const std::vector<float>& code = s.code;
  const float far = s.far;  // the farthest foreground depth (Segment)
  const double block_px = far > 0 ? kBlockDim * h * std::min(view.K.fx, view.K.fy) / far : 1;
  const int stride = std::clamp(static_cast<int>(block_px / 3), 1, 8);
  const int steps = static_cast<int>(std::ceil(2 * mu / (0.5 * kBlockDim * h)));
  std::array<double, 64> along;  // metres along the ray (steps <= 8: truncation <= 2 blocks)
  for (int k = 0; k <= steps; ++k) along[k] = -mu + 2 * mu * k / steps;
  const size_t words = (grid.size() + 63) / 64;
  if (s.seen.size() != words) s.seen.assign(words, 0);
  std::unordered_map<uint64_t, bool> off_grid;  // blocks outside the grid (none expected)
  BandSamples a;
  a.R = view.R, a.t = view.t;
  a.along = along.data(), a.samples = steps + 1;
  a.h = h, a.inv_h = 1 / h;
  a.grid_lo = grid_lo, a.grid_dims = grid_dims;
  const size_t max_pixels = size_t(std::max(0, s.fg_u1 - s.fg_u0)) / stride + 9;
  if (s.band_xhat.size() < max_pixels) s.band_xhat.resize(max_pixels), s.band_d.resize(max_pixels);
  if (s.band_out.size() < max_pixels * a.samples) s.band_out.resize(max_pixels * a.samples);
  // The sample grid is anchored at pixel (0, 0) whatever the rectangle; only the
  // foreground's bounding rectangle (Segment) holds samples.
  const int ustart = (s.fg_u0 + stride - 1) / stride * stride, vstart = (s.fg_v0 + stride - 1) / stride * stride;
  for (int v = vstart; v < s.fg_v1; v += stride) {
    const float* row = &code[size_t(v) * view.W];
    int n = 0;
    for (int u = ustart; u < s.fg_u1; u += stride) {
      const float d = row[u];
      if (!(d > 0)) continue;
      s.band_xhat[n] = xhat[u], s.band_d[n] = d;
      ++n;
    }
    if (n == 0) continue;
    for (int i = n; i % 8; ++i) s.band_xhat[i] = s.band_xhat[n - 1], s.band_d[i] = s.band_d[n - 1];
    a.xhat = s.band_xhat.data(), a.d = s.band_d.data(), a.n = n, a.yv = yhat[v];
    samples_kernel(a, s.band_out.data());
    for (int i = 0; i < n; ++i) {
      const int32_t* out = &s.band_out[size_t(i / 8) * 8 * a.samples + i % 8];
      for (int k = 0; k < a.samples; ++k) {
        int64_t g = out[8 * ptrdiff_t(k)];
        if (g == -1) continue;
        Eigen::Vector3i b(0, 0, 0);
        if (g == -2) {
          if (!BandSampleBlockAt(a, i, k, &b)) continue;
          g = GridIndex(b);
        }
        if (g >= 0) {
          uint64_t& word = s.seen[size_t(g) >> 6];
          const uint64_t bit = uint64_t(1) << (g & 63);
          if (word & bit) continue;
          word |= bit;
          b = grid_lo + Eigen::Vector3i(int(g / (int64_t(grid_dims.y()) * grid_dims.z())),
                                        int(g / grid_dims.z() % grid_dims.y()), int(g % grid_dims.z()));
        } else if (!off_grid.emplace(Key(b), true).second) {
          continue;
        }
        band.push_back(b);
      }
    }
  }
  for (const Eigen::Vector3i& b : band) {
    const int64_t g = GridIndex(b);
    if (g >= 0) s.seen[size_t(g) >> 6] = 0;
  }
}

bool BandSampleBlockAt(const BandSamples& a, int i, int k, Eigen::Vector3i* b) {
  const double lambda = std::sqrt(1 + a.xhat[i] * a.xhat[i] + a.yv * a.yv);
  const Vec3 ray = a.R * Vec3(a.xhat[i], a.yv, 1.0);
  const double z = a.d[i] + a.along[k] / lambda;
  if (z <= 0) return false;
  const Vec3 p = z * ray + a.t;
  *b = BandSampleBlock(p, a.h, a.inv_h);
  return true;
}

namespace {

int32_t BandGridIndex(const BandSamples& a, const Eigen::Vector3i& b) {
  const Eigen::Vector3i r = b - a.grid_lo;
  if ((r.array() < 0).any() || (r.array() >= a.grid_dims.array()).any()) return -2;
  return (r.x() * a.grid_dims.y() + r.y()) * a.grid_dims.z() + r.z();
}

}  // namespace

void BandSamplesScalar(const BandSamples& a, int32_t* out) {
  for (int i = 0; i < a.n; ++i) {
    int32_t* o = out + size_t(i / 8) * 8 * a.samples + i % 8;
    // BandSampleBlockAt with the pixel's λ and ray computed once.
    const double lambda = std::sqrt(1 + a.xhat[i] * a.xhat[i] + a.yv * a.yv);
    const Vec3 ray = a.R * Vec3(a.xhat[i], a.yv, 1.0);
    for (int k = 0; k < a.samples; ++k) {
      const double z = a.d[i] + a.along[k] / lambda;
      o[8 * ptrdiff_t(k)] = z <= 0 ? -1 : BandGridIndex(a, BandSampleBlock(z * ray + a.t, a.h, a.inv_h));
    }
  }
}

#if defined(__x86_64__)
bool HaveAvx512VlBw() {
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw");
}

// BandSamplesScalar on 8 pixels at a time (doubles, the same operations in the same
// order; no FMA: tsdf.cpp is compiled with -ffp-contract=off). The voxel's rounding
// by the multiplication (FloorVoxel) where it is decided, -2 where the division decides.
__attribute__((target("avx512f,avx512vl,avx512bw"))) void BandSamplesAvx512(const BandSamples& a, int32_t* out) {
  const __m512d one = _mm512_set1_pd(1.0), half = _mm512_set1_pd(0.5), inv_h = _mm512_set1_pd(a.inv_h);
  const __m512d yv = _mm512_set1_pd(a.yv), zero = _mm512_setzero_pd();
  const __m512d qmax = _mm512_set1_pd(1e6), flo = _mm512_set1_pd(1e-9), fhi = _mm512_set1_pd(1 - 1e-9);
  __m512d R[3][3], t[3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R[r][c] = _mm512_set1_pd(a.R(r, c));
    t[r] = _mm512_set1_pd(a.t[r]);
  }
  const __m256i lo[3] = {_mm256_set1_epi32(a.grid_lo.x()), _mm256_set1_epi32(a.grid_lo.y()),
                         _mm256_set1_epi32(a.grid_lo.z())};
  const __m256i dims[3] = {_mm256_set1_epi32(a.grid_dims.x()), _mm256_set1_epi32(a.grid_dims.y()),
                           _mm256_set1_epi32(a.grid_dims.z())};
  const __m256i none = _mm256_set1_epi32(-1), undecided = _mm256_set1_epi32(-2);
  for (int i0 = 0; i0 < a.n; i0 += 8) {
    const __m512d x = _mm512_loadu_pd(a.xhat + i0), d = _mm512_loadu_pd(a.d + i0);
    const __m512d lambda =
        _mm512_maskz_sqrt_pd(0xff, _mm512_add_pd(_mm512_add_pd(one, _mm512_mul_pd(x, x)), _mm512_mul_pd(yv, yv)));
    __m512d ray[3];
    for (int r = 0; r < 3; ++r) {
      const __m512d a0 = _mm512_mul_pd(R[r][0], x), a1 = _mm512_mul_pd(R[r][1], yv), a2 = _mm512_mul_pd(R[r][2], one);
      ray[r] = r < 2 ? _mm512_add_pd(_mm512_add_pd(a0, a1), a2) : _mm512_add_pd(a0, _mm512_add_pd(a1, a2));
    }
    int32_t* o = out + size_t(i0) * a.samples;
    for (int k = 0; k < a.samples; ++k) {
      const __m512d z = _mm512_add_pd(d, _mm512_div_pd(_mm512_set1_pd(a.along[k]), lambda));
      const __mmask8 sample = _mm512_cmp_pd_mask(z, zero, _CMP_NLE_UQ);  // !(z <= 0)
      __mmask8 decided = 0xff, inside = 0xff;
      __m256i r[3];
      for (int c = 0; c < 3; ++c) {
        const __m512d p = _mm512_add_pd(_mm512_mul_pd(z, ray[c]), t[c]);
        const __m512d q = _mm512_add_pd(_mm512_mul_pd(p, inv_h), half);
        const __m512d fl = _mm512_maskz_roundscale_pd(0xff, q, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
        const __m512d f = _mm512_sub_pd(q, fl);
        decided &= _mm512_cmp_pd_mask(_mm512_abs_pd(q), qmax, _CMP_LT_OQ) & _mm512_cmp_pd_mask(f, flo, _CMP_GT_OQ) &
                   _mm512_cmp_pd_mask(f, fhi, _CMP_LT_OQ);
        // The voxel, its block (floor division by 8), relative to the grid.
        const __m256i voxel = _mm512_maskz_cvttpd_epi32(0xff, fl);
        r[c] = _mm256_sub_epi32(_mm256_srai_epi32(voxel, 3), lo[c]);
        inside &= _mm256_cmpge_epi32_mask(r[c], _mm256_setzero_si256()) & _mm256_cmplt_epi32_mask(r[c], dims[c]);
      }
      const __m256i g = _mm256_add_epi32(
          _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(r[0], dims[1]), r[1]), dims[2]), r[2]);
      __m256i res = _mm256_mask_mov_epi32(undecided, decided & inside, g);
      res = _mm256_mask_mov_epi32(none, sample, res);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(o + 8 * ptrdiff_t(k)), res);
    }
  }
}
#else
bool HaveAvx512VlBw() { return false; }
void BandSamplesAvx512(const BandSamples& a, int32_t* out) { BandSamplesScalar(a, out); }
#endif

VoxelProjector ProjectorFor(const FrameView& view, const Eigen::Vector3i& block, double h, double mu) {
  VoxelProjector p;
  const Vec3 origin = block.cast<double>() * (kBlockDim * h);
  p.c0 = (view.Rt * (origin - view.t)).cast<float>();
  p.ex = (view.Rt.col(0) * h).cast<float>();
  p.ey = (view.Rt.col(1) * h).cast<float>();
  p.ez = (view.Rt.col(2) * h).cast<float>();
  p.fx = float(view.K.fx), p.fy = float(view.K.fy), p.cx = float(view.K.cx), p.cy = float(view.K.cy);
  p.mu = float(mu);
  p.W = view.W, p.H = view.H;
  return p;
}

// The projective update of one voxel (KinectFusion): sdf = (d - z)·|ray|/z_ray along
// the pixel's ray, clamped to +μ, skipped below -μ; weights count observations.
int64_t UpdateBlockScalar(FusionBlock& blk, const VoxelProjector& p, const float* code) {
  int64_t n = 0;
  for (int x = 0; x < kBlockDim; ++x) {
    for (int y = 0; y < kBlockDim; ++y) {
      const Eigen::Vector3f cxy = p.c0 + float(x) * p.ex + float(y) * p.ey;
      for (int z = 0; z < kBlockDim; ++z) {
        const float cxv = cxy.x() + float(z) * p.ez.x(), cyv = cxy.y() + float(z) * p.ez.y(),
                    zc = cxy.z() + float(z) * p.ez.z();
        if (zc <= 1e-6f) continue;
        const float inv = 1.0f / zc;
        // Rounded to the nearest pixel; truncation is floor for the non-negative
        // values kept (std::floor is a libm call without SSE4.1).
        const float uf = p.fx * cxv * inv + p.cx + 0.5f, vf = p.fy * cyv * inv + p.cy + 0.5f;
        if (!(uf >= 0 && vf >= 0 && uf < float(p.W) && vf < float(p.H))) continue;
        const int iu = static_cast<int>(uf), iv = static_cast<int>(vf);
        const float d = code[size_t(iv) * p.W + iu];
        // Distance along the ray per unit of depth (computed, not looked up: one
        // image fetch per voxel is the cache-bound part).
        const float lambda = std::sqrt(cxv * cxv + cyv * cyv + zc * zc) * inv;
        float value;
        if (d > 0 && (d - zc) * lambda <= p.mu) {
          const float sdf = (d - zc) * lambda;
          if (sdf < -p.mu) continue;
          value = sdf;  // the band around an observed garment surface
        } else {
          // Free space in front of an observed depth (garment or scene). Pixels
          // without data carve only at block level (CarveBlocks), where a share of the
          // views is required: dropouts are too frequent over a long sweep.
          if (!(std::abs(d) > 0) || (std::abs(d) - zc) * lambda <= p.mu) continue;  // NaN, 0 too
          value = p.mu;
        }
        const int o = LocalOffset(x, y, z);
        const float w = blk.weight[o];
        blk.tsdf[o] = (blk.tsdf[o] * w + value) / (w + 1);
        blk.weight[o] = w + 1;
        ++n;
      }
    }
  }
  return n;
}

// Segment's box test, one row at a time (see SegmentRow in tsdf_impl.h).
int64_t SegmentRowScalar(const SegmentRow& a, int u0, int u1, float* far) {
  int64_t n = 0;
  for (int u = u0; u < u1; ++u) {
    const float d = a.depth[u];
    a.fg[u] = 0;
    if (!(d > 0) || !std::isfinite(d)) {
      a.code[u] = 0;
      continue;
    }
    const double x = d * a.xhat[u], y = d * a.yv, z = d;
    double p[3];
    for (int i = 0; i < 2; ++i) p[i] = ((a.R[i][0] * x + a.R[i][1] * y) + a.R[i][2] * z) + a.t[i];
    p[2] = (a.R[2][0] * x + (a.R[2][1] * y + a.R[2][2] * z)) + a.t[2];
    const bool in = a.lo[0] <= p[0] && a.lo[1] <= p[1] && a.lo[2] <= p[2] && p[0] <= a.hi[0] && p[1] <= a.hi[1] &&
                    p[2] <= a.hi[2] && (a.radius2 <= 0 || p[0] * p[0] + p[2] * p[2] <= a.radius2);
    a.code[u] = in ? d : -d;
    a.fg[u] = in;
    n += in;
    if (in) {
      *far = std::max(*far, d);
      a.fg_lo = std::min(a.fg_lo, u), a.fg_hi = std::max(a.fg_hi, u + 1);
    }
  }
  return n;
}

#if defined(__x86_64__)
// The same 4 pixels at a time (doubles; no FMA: the same bits).
__attribute__((target("avx2"))) int64_t SegmentRowAvx2(const SegmentRow& a, int u0, int u1, float* far) {
  int64_t n = 0;
  const __m256d yv = _mm256_set1_pd(a.yv), r2 = _mm256_set1_pd(a.radius2);
  __m256d R[3][3], t[3], lo[3], hi[3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R[i][j] = _mm256_set1_pd(a.R[i][j]);
    t[i] = _mm256_set1_pd(a.t[i]), lo[i] = _mm256_set1_pd(a.lo[i]), hi[i] = _mm256_set1_pd(a.hi[i]);
  }
  const bool radial = a.radius2 > 0;
  const __m128 zero = _mm_setzero_ps(), inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m256i low_halves = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
  __m128 far4 = zero;  // per lane: the largest foreground depth
  int u = u0;
  for (; u + 4 <= u1; u += 4) {
    const __m128 d = _mm_loadu_ps(a.depth + u);
    // d > 0 and finite (NaN fails both).
    const __m128 valid = _mm_and_ps(_mm_cmpgt_ps(d, zero), _mm_cmplt_ps(d, inf));
    const __m256d dd = _mm256_cvtps_pd(d);
    const __m256d x = _mm256_mul_pd(dd, _mm256_loadu_pd(a.xhat + u)), y = _mm256_mul_pd(dd, yv);
    __m256d in = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    __m256d p[3];
    for (int i = 0; i < 3; ++i) {
      const __m256d a0 = _mm256_mul_pd(R[i][0], x), a1 = _mm256_mul_pd(R[i][1], y), a2 = _mm256_mul_pd(R[i][2], dd);
      const __m256d sum = i < 2 ? _mm256_add_pd(_mm256_add_pd(a0, a1), a2) : _mm256_add_pd(a0, _mm256_add_pd(a1, a2));
      p[i] = _mm256_add_pd(sum, t[i]);
      in = _mm256_and_pd(in,
                         _mm256_and_pd(_mm256_cmp_pd(lo[i], p[i], _CMP_LE_OQ), _mm256_cmp_pd(p[i], hi[i], _CMP_LE_OQ)));
    }
    if (radial) {
      const __m256d rr = _mm256_add_pd(_mm256_mul_pd(p[0], p[0]), _mm256_mul_pd(p[2], p[2]));
      in = _mm256_and_pd(in, _mm256_cmp_pd(rr, r2, _CMP_LE_OQ));
    }
    // 64-bit lane masks → 32-bit lane masks.
    const __m128 in4 = _mm256_castps256_ps128(_mm256_permutevar8x32_ps(_mm256_castpd_ps(in), low_halves));
    const __m128 fg = _mm_and_ps(valid, in4);
    // valid: in ? d : -d; else 0.
    const __m128 code = _mm_and_ps(valid, _mm_or_ps(d, _mm_andnot_ps(in4, sign)));
    _mm_storeu_ps(a.code + u, code);
    far4 = _mm_max_ps(far4, _mm_and_ps(fg, d));
    const int bits = _mm_movemask_ps(fg);
    if (bits) {
      a.fg_lo = std::min(a.fg_lo, u + __builtin_ctz(bits));
      a.fg_hi = std::max(a.fg_hi, u + 32 - __builtin_clz(bits));
    }
    for (int k = 0; k < 4; ++k) a.fg[u + k] = (bits >> k) & 1;
    n += __builtin_popcount(bits);
  }
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, far4);
  for (float f : lanes) *far = std::max(*far, f);
  return n + SegmentRowScalar(a, u, u1, far);
}

// The same 8 pixels at a time (AVX-512 doubles; no FMA: the same bits).
__attribute__((target("avx512f,avx512vl,avx512bw"))) int64_t SegmentRowAvx512(const SegmentRow& a, int u0, int u1,
                                                                              float* far) {
  int64_t n = 0;
  const __m512d yv = _mm512_set1_pd(a.yv), r2 = _mm512_set1_pd(a.radius2);
  __m512d R[3][3], t[3], lo[3], hi[3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R[i][j] = _mm512_set1_pd(a.R[i][j]);
    t[i] = _mm512_set1_pd(a.t[i]), lo[i] = _mm512_set1_pd(a.lo[i]), hi[i] = _mm512_set1_pd(a.hi[i]);
  }
  const bool radial = a.radius2 > 0;
  const __m256 zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(std::numeric_limits<float>::infinity());
  const __m256 sign = _mm256_set1_ps(-0.0f);
  const __m128i ones = _mm_set1_epi8(1);
  __m256 far8 = zero;  // per lane: the largest foreground depth
  int u = u0;
  for (; u + 8 <= u1; u += 8) {
    const __m256 d = _mm256_loadu_ps(a.depth + u);
    // d > 0 and finite (NaN fails both).
    const __mmask8 valid = _mm256_cmp_ps_mask(d, zero, _CMP_GT_OQ) & _mm256_cmp_ps_mask(d, inf, _CMP_LT_OQ);
    const __m512d dd = _mm512_maskz_cvtps_pd(0xff, d);
    const __m512d x = _mm512_mul_pd(dd, _mm512_loadu_pd(a.xhat + u)), y = _mm512_mul_pd(dd, yv);
    __mmask8 in = 0xff;
    __m512d p[3];
    for (int i = 0; i < 3; ++i) {
      const __m512d a0 = _mm512_mul_pd(R[i][0], x), a1 = _mm512_mul_pd(R[i][1], y), a2 = _mm512_mul_pd(R[i][2], dd);
      const __m512d sum = i < 2 ? _mm512_add_pd(_mm512_add_pd(a0, a1), a2) : _mm512_add_pd(a0, _mm512_add_pd(a1, a2));
      p[i] = _mm512_add_pd(sum, t[i]);
      in &= _mm512_cmp_pd_mask(lo[i], p[i], _CMP_LE_OQ) & _mm512_cmp_pd_mask(p[i], hi[i], _CMP_LE_OQ);
    }
    if (radial) {
      const __m512d rr = _mm512_add_pd(_mm512_mul_pd(p[0], p[0]), _mm512_mul_pd(p[2], p[2]));
      in &= _mm512_cmp_pd_mask(rr, r2, _CMP_LE_OQ);
    }
    const __mmask8 fg = valid & in;
    // valid: in ? d : -d; else 0.
    const __m256i di = _mm256_castps_si256(d);
    const __m256i negated = _mm256_mask_or_epi32(di, __mmask8(~in), di, _mm256_castps_si256(sign));
    _mm256_storeu_ps(a.code + u, _mm256_maskz_mov_ps(valid, _mm256_castsi256_ps(negated)));
    far8 = _mm256_max_ps(far8, _mm256_maskz_mov_ps(fg, d));
    const int bits = fg;
    if (bits) {
      a.fg_lo = std::min(a.fg_lo, u + __builtin_ctz(bits));
      a.fg_hi = std::max(a.fg_hi, u + 32 - __builtin_clz(bits));
    }
    _mm_storel_epi64(reinterpret_cast<__m128i*>(a.fg + u), _mm_maskz_mov_epi8(fg, ones));
    n += __builtin_popcount(bits);
  }
  alignas(32) float lanes[8];
  _mm256_store_ps(lanes, far8);
  for (float f : lanes) *far = std::max(*far, f);
  return n + SegmentRowScalar(a, u, u1, far);
}
#else
int64_t SegmentRowAvx2(const SegmentRow& a, int u0, int u1, float* far) { return SegmentRowScalar(a, u0, u1, far); }
int64_t SegmentRowAvx512(const SegmentRow& a, int u0, int u1, float* far) { return SegmentRowScalar(a, u0, u1, far); }
#endif

#if defined(__x86_64__)
bool HaveAvx2() { return __builtin_cpu_supports("avx2"); }

// UpdateBlockScalar on the 8 voxels of a z row at once. Same operations in the same
// order (no FMA: target avx2 only), so the same bits.
__attribute__((target("avx2"))) int64_t UpdateBlockAvx2(FusionBlock& blk, const VoxelProjector& p, const float* code) {
  const __m256 zi = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 ezx = _mm256_mul_ps(zi, _mm256_set1_ps(p.ez.x()));
  const __m256 ezy = _mm256_mul_ps(zi, _mm256_set1_ps(p.ez.y()));
  const __m256 ezz = _mm256_mul_ps(zi, _mm256_set1_ps(p.ez.z()));
  const __m256 fx = _mm256_set1_ps(p.fx), fy = _mm256_set1_ps(p.fy), cx = _mm256_set1_ps(p.cx),
               cy = _mm256_set1_ps(p.cy), half = _mm256_set1_ps(0.5f), one = _mm256_set1_ps(1.0f),
               zero = _mm256_setzero_ps(), Wf = _mm256_set1_ps(float(p.W)), Hf = _mm256_set1_ps(float(p.H)),
               mu = _mm256_set1_ps(p.mu), neg_mu = _mm256_set1_ps(-p.mu), eps = _mm256_set1_ps(1e-6f);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256i Wi = _mm256_set1_epi32(p.W);
  int64_t n = 0;
  for (int x = 0; x < kBlockDim; ++x) {
    for (int y = 0; y < kBlockDim; ++y) {
      const Eigen::Vector3f cxy = p.c0 + float(x) * p.ex + float(y) * p.ey;
      const __m256 cxv = _mm256_add_ps(_mm256_set1_ps(cxy.x()), ezx);
      const __m256 cyv = _mm256_add_ps(_mm256_set1_ps(cxy.y()), ezy);
      const __m256 zc = _mm256_add_ps(_mm256_set1_ps(cxy.z()), ezz);
      __m256 keep = _mm256_cmp_ps(zc, eps, _CMP_GT_OQ);
      const __m256 inv = _mm256_div_ps(one, zc);
      const __m256 uf = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(fx, cxv), inv), cx), half);
      const __m256 vf = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(fy, cyv), inv), cy), half);
      keep =
          _mm256_and_ps(keep, _mm256_and_ps(_mm256_cmp_ps(uf, zero, _CMP_GE_OQ), _mm256_cmp_ps(vf, zero, _CMP_GE_OQ)));
      keep = _mm256_and_ps(keep, _mm256_and_ps(_mm256_cmp_ps(uf, Wf, _CMP_LT_OQ), _mm256_cmp_ps(vf, Hf, _CMP_LT_OQ)));
      if (_mm256_movemask_ps(keep) == 0) continue;
      const __m256i pix = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(vf), Wi), _mm256_cvttps_epi32(uf));
      const __m256 d = _mm256_mask_i32gather_ps(zero, code, pix, keep, 4);
      const __m256 len2 =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(cxv, cxv), _mm256_mul_ps(cyv, cyv)), _mm256_mul_ps(zc, zc));
      const __m256 lambda = _mm256_mul_ps(_mm256_sqrt_ps(len2), inv);
      const __m256 sdf = _mm256_mul_ps(_mm256_sub_ps(d, zc), lambda);
      const __m256 band = _mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_GT_OQ), _mm256_cmp_ps(sdf, mu, _CMP_LE_OQ));
      const __m256 band_keep = _mm256_andnot_ps(_mm256_cmp_ps(sdf, neg_mu, _CMP_LT_OQ), band);
      const __m256 ad = _mm256_and_ps(d, abs_mask);
      const __m256 free_ = _mm256_andnot_ps(
          band, _mm256_and_ps(_mm256_cmp_ps(ad, zero, _CMP_GT_OQ),
                              _mm256_cmp_ps(_mm256_mul_ps(_mm256_sub_ps(ad, zc), lambda), mu, _CMP_NLE_UQ)));
      keep = _mm256_and_ps(keep, _mm256_or_ps(band_keep, free_));
      const int bits = _mm256_movemask_ps(keep);
      if (bits == 0) continue;
      const __m256 value = _mm256_blendv_ps(mu, sdf, band);
      float* tp = &blk.tsdf[LocalOffset(x, y, 0)];
      float* wp = &blk.weight[LocalOffset(x, y, 0)];
      const __m256 w = _mm256_loadu_ps(wp), t = _mm256_loadu_ps(tp);
      const __m256 w1 = _mm256_add_ps(w, one);
      const __m256 tn = _mm256_div_ps(_mm256_add_ps(_mm256_mul_ps(t, w), value), w1);
      _mm256_storeu_ps(tp, _mm256_blendv_ps(t, tn, keep));
      _mm256_storeu_ps(wp, _mm256_blendv_ps(w, w1, keep));
      n += __builtin_popcount(bits);
    }
  }
  return n;
}
bool HaveAvx512() { return __builtin_cpu_supports("avx512f"); }

// a in lanes 0-7, b in lanes 8-15.
__attribute__((target("avx512f"))) inline __m512 Pair(float a, float b) {
  return _mm512_mask_blend_ps(0xff00, _mm512_set1_ps(a), _mm512_set1_ps(b));
}

// UpdateBlockScalar on two z rows (16 voxels) at once: the same operations in the same
// order (tsdf.cpp is compiled with -ffp-contract=off: no FMA), so the same bits. No
// branch in the loop (masked gather and stores), so rows overlap in the pipeline.
__attribute__((target("avx512f"))) int64_t UpdateBlockAvx512(FusionBlock& blk, const VoxelProjector& p,
                                                             const float* code) {
  const __m512 zi = _mm512_setr_ps(0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7);
  const __m512 ezx = _mm512_mul_ps(zi, _mm512_set1_ps(p.ez.x()));
  const __m512 ezy = _mm512_mul_ps(zi, _mm512_set1_ps(p.ez.y()));
  const __m512 ezz = _mm512_mul_ps(zi, _mm512_set1_ps(p.ez.z()));
  const __m512 fx = _mm512_set1_ps(p.fx), fy = _mm512_set1_ps(p.fy), cx = _mm512_set1_ps(p.cx),
               cy = _mm512_set1_ps(p.cy), half = _mm512_set1_ps(0.5f), one = _mm512_set1_ps(1.0f),
               zero = _mm512_setzero_ps(), Wf = _mm512_set1_ps(float(p.W)), Hf = _mm512_set1_ps(float(p.H)),
               mu = _mm512_set1_ps(p.mu), neg_mu = _mm512_set1_ps(-p.mu), eps = _mm512_set1_ps(1e-6f);
  const __m512i Wi = _mm512_set1_epi32(p.W);
  const __m512i abs_mask = _mm512_set1_epi32(0x7fffffff);
  int64_t n = 0;
  for (int x = 0; x < kBlockDim; ++x) {
    for (int y = 0; y < kBlockDim; y += 2) {
      const Eigen::Vector3f c_a = p.c0 + float(x) * p.ex + float(y) * p.ey;
      const Eigen::Vector3f c_b = p.c0 + float(x) * p.ex + float(y + 1) * p.ey;
      const __m512 cxv = _mm512_add_ps(Pair(c_a.x(), c_b.x()), ezx);
      const __m512 cyv = _mm512_add_ps(Pair(c_a.y(), c_b.y()), ezy);
      const __m512 zc = _mm512_add_ps(Pair(c_a.z(), c_b.z()), ezz);
      __mmask16 keep = _mm512_cmp_ps_mask(zc, eps, _CMP_GT_OQ);
      const __m512 inv = _mm512_div_ps(one, zc);
      const __m512 uf = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(fx, cxv), inv), cx), half);
      const __m512 vf = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(_mm512_mul_ps(fy, cyv), inv), cy), half);
      keep &= _mm512_cmp_ps_mask(uf, zero, _CMP_GE_OQ) & _mm512_cmp_ps_mask(vf, zero, _CMP_GE_OQ) &
              _mm512_cmp_ps_mask(uf, Wf, _CMP_LT_OQ) & _mm512_cmp_ps_mask(vf, Hf, _CMP_LT_OQ);
      // (maskz forms: GCC 12's unmasked ones read an uninitialised register and warn)
      const __m512i pix = _mm512_add_epi32(_mm512_mullo_epi32(_mm512_maskz_cvttps_epi32(0xffff, vf), Wi),
                                           _mm512_maskz_cvttps_epi32(0xffff, uf));
      const __m512 d = _mm512_mask_i32gather_ps(zero, keep, pix, code, 4);
      const __m512 len2 =
          _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(cxv, cxv), _mm512_mul_ps(cyv, cyv)), _mm512_mul_ps(zc, zc));
      const __m512 lambda = _mm512_mul_ps(_mm512_maskz_sqrt_ps(0xffff, len2), inv);
      const __m512 sdf = _mm512_mul_ps(_mm512_sub_ps(d, zc), lambda);
      const __mmask16 band = _mm512_cmp_ps_mask(d, zero, _CMP_GT_OQ) & _mm512_cmp_ps_mask(sdf, mu, _CMP_LE_OQ);
      const __mmask16 band_keep = band & ~_mm512_cmp_ps_mask(sdf, neg_mu, _CMP_LT_OQ);
      const __m512 ad = _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(d), abs_mask));
      const __mmask16 free_ = ~band & _mm512_cmp_ps_mask(ad, zero, _CMP_GT_OQ) &
                              _mm512_cmp_ps_mask(_mm512_mul_ps(_mm512_sub_ps(ad, zc), lambda), mu, _CMP_NLE_UQ);
      keep &= band_keep | free_;
      const __m512 value = _mm512_mask_blend_ps(band, mu, sdf);
      float* tp = &blk.tsdf[LocalOffset(x, y, 0)];
      float* wp = &blk.weight[LocalOffset(x, y, 0)];
      const __m512 w = _mm512_loadu_ps(wp), t = _mm512_loadu_ps(tp);
      const __m512 w1 = _mm512_add_ps(w, one);
      const __m512 tn = _mm512_div_ps(_mm512_add_ps(_mm512_mul_ps(t, w), value), w1);
      _mm512_mask_storeu_ps(tp, keep, tn);
      _mm512_mask_storeu_ps(wp, keep, w1);
      n += __builtin_popcount(keep);
    }
  }
  return n;
}
#else
bool HaveAvx2() { return false; }
int64_t UpdateBlockAvx2(FusionBlock& blk, const VoxelProjector& p, const float* code) {
  return UpdateBlockScalar(blk, p, code);
}
bool HaveAvx512() { return false; }
int64_t UpdateBlockAvx512(FusionBlock& blk, const VoxelProjector& p, const float* code) {
  return UpdateBlockScalar(blk, p, code);
}
#endif

// 4. Projective TSDF update of every voxel of the blocks the batch's frames touch,
// block by block (a block's 4 KB stay in cache over the frames), each block's frames
// in order. Blocks are independent, so any thread count gives the same values.
void Tsdf::Impl::UpdateVoxels(const std::vector<PreparedFrame*>& batch) {
  static const auto update = HaveAvx512() ? UpdateBlockAvx512 : HaveAvx2() ? UpdateBlockAvx2 : UpdateBlockScalar;
  // The blocks in the order first touched, with the frames that touch each (CSR).
  std::vector<int> slot_of(blocks.size(), -1), order, count;
  for (const PreparedFrame* f : batch) {
    for (int bi : f->touched) {
      if (slot_of[bi] < 0) {
        slot_of[bi] = static_cast<int>(order.size());
        order.push_back(bi);
        count.push_back(0);
      }
      ++count[slot_of[bi]];
    }
  }
  const int slots = static_cast<int>(order.size());
  std::vector<int> start(slots + 1, 0);
  for (int k = 0; k < slots; ++k) start[k + 1] = start[k] + count[k];
  std::vector<int> frame_of(start[slots]);
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (size_t fi = 0; fi < batch.size(); ++fi)
    for (int bi : batch[fi]->touched) frame_of[fill[slot_of[bi]]++] = static_cast<int>(fi);
  constexpr int kChunk = 16;  // blocks per task
  const int chunks = (slots + kChunk - 1) / kChunk;
  std::vector<int64_t> updates(chunks, 0);
  ParallelFor(chunks, opt.threads, [&](int c) {
    int64_t n = 0;
    for (int k = c * kChunk; k < std::min(slots, (c + 1) * kChunk); ++k) {
      FusionBlock& blk = *blocks[order[k]];
      for (int j = start[k]; j < start[k + 1]; ++j) {
        const PreparedFrame& f = *batch[frame_of[j]];
        const VoxelProjector p = ProjectorFor(f.view, blk.coord, h, mu);
        const float* code = f.scratch.code.data();
        n += update(blk, p, code);
      }
    }
    updates[c] = n;
  });
  for (int64_t u : updates) voxel_updates += u;
}

// 5. Space carving at block resolution (block centres), over the cells that can end
// up inside (see MakeView), cell by cell over the batch's frames in order (a cell's
// counts decide whether a later frame still counts for it), slabs of cells in parallel.
void Tsdf::Impl::CarveBlocks(const std::vector<PreparedFrame*>& batch) {
  static const auto carve_run = HaveAvx512VlBw() ? CarveRunAvx512 : CarveRunScalar;
  const Eigen::Vector3i& dims = carve_dims;
  Eigen::Vector3i lo = batch[0]->view.cell_lo, hi = batch[0]->view.cell_hi;
  for (const PreparedFrame* f : batch) lo = lo.cwiseMin(f->view.cell_lo), hi = hi.cwiseMax(f->view.cell_hi);
  ParallelFor(std::max(0, hi.x() - lo.x() + 1), opt.threads, [&](int i) {
    const int bx = lo.x() + i;
    CarveRun a;
    a.h = h, a.mu = mu;
    for (int by = lo.y(); by <= hi.y(); ++by) {
      for (const PreparedFrame* f : batch) {
        const FrameView& view = f->view;
        if (bx < view.cell_lo.x() || bx > view.cell_hi.x() || by < view.cell_lo.y() || by > view.cell_hi.y()) continue;
        if (view.cell_lo.z() > view.cell_hi.z()) continue;
        const size_t ci = (size_t(bx) * dims.y() + by) * dims.z() + view.cell_lo.z();
        const Eigen::Vector3i b = carve_lo + Eigen::Vector3i(bx, by, view.cell_lo.z());
        const Vec3 p = (b.cast<double>() * kBlockDim + Vec3::Constant(3.5)) * h;
        a.px = p.x(), a.py = p.y(), a.bz0 = b.z(), a.n = view.cell_hi.z() - view.cell_lo.z() + 1;
        a.Rt = view.Rt, a.t = view.t;
        a.fx = view.K.fx, a.fy = view.K.fy, a.cx = view.K.cx, a.cy = view.K.cy, a.W = view.W, a.H = view.H;
        a.code = f->scratch.code.data();
        a.view_count = &view_count[ci], a.free_count = &free_count[ci];
        carve_run(a);
      }
    }
  });
}

void CarveRunScalar(const CarveRun& a) {
  const int cap = std::numeric_limits<uint16_t>::max();
  for (int i = 0; i < a.n; ++i) {
    uint16_t& views = a.view_count[i];
    uint16_t& frees = a.free_count[i];
    // Free in half of 16+ views: outside for good, whatever follows.
    if (views >= 16 && 2 * frees >= views) continue;
    const Vec3 p(a.px, a.py, (double(a.bz0 + i) * kBlockDim + 3.5) * a.h);
    const Vec3 c = a.Rt * (p - a.t);
    if (c.z() <= 1e-6) continue;
    const int iu = static_cast<int>(std::floor(a.fx * c.x() / c.z() + a.cx + 0.5));
    const int iv = static_cast<int>(std::floor(a.fy * c.y() / c.z() + a.cy + 0.5));
    if (iu < 0 || iv < 0 || iu >= a.W || iv >= a.H) continue;
    if (views < cap) ++views;
    const float d = a.code[size_t(iv) * a.W + iu];
    if (std::isnan(d)) continue;
    const double lambda = c.norm() / c.z();
    const bool free = d == 0 || (std::abs(d) - c.z()) * lambda > a.mu;
    if (free && frees < cap) ++frees;
  }
}

#if defined(__x86_64__)
// CarveRunScalar on 8 cells at a time.
__attribute__((target("avx512f,avx512vl,avx512bw"))) void CarveRunAvx512(const CarveRun& a) {
  const __m512d zi = _mm512_setr_pd(0, 1, 2, 3, 4, 5, 6, 7);
  const __m512d eight = _mm512_set1_pd(kBlockDim), c35 = _mm512_set1_pd(3.5), h = _mm512_set1_pd(a.h);
  const __m512d half = _mm512_set1_pd(0.5), eps = _mm512_set1_pd(1e-6), mu = _mm512_set1_pd(a.mu);
  const __m512d fx = _mm512_set1_pd(a.fx), fy = _mm512_set1_pd(a.fy), cx = _mm512_set1_pd(a.cx),
                cy = _mm512_set1_pd(a.cy);
  __m512d R[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R[r][c] = _mm512_set1_pd(a.Rt(r, c));
  const __m512d x = _mm512_sub_pd(_mm512_set1_pd(a.px), _mm512_set1_pd(a.t.x()));
  const __m512d y = _mm512_sub_pd(_mm512_set1_pd(a.py), _mm512_set1_pd(a.t.y()));
  const __m512d tz = _mm512_set1_pd(a.t.z());
  const __m256i W = _mm256_set1_epi32(a.W), H = _mm256_set1_epi32(a.H), zero = _mm256_setzero_si256();
  const __m256i sixteen = _mm256_set1_epi32(16);
  const __m128i one16 = _mm_set1_epi16(1);
  for (int i0 = 0; i0 < a.n; i0 += 8) {
    const __mmask8 lanes = a.n - i0 >= 8 ? 0xff : __mmask8((1u << (a.n - i0)) - 1);
    const __m128i views16 = _mm_maskz_loadu_epi16(lanes, a.view_count + i0);
    const __m128i frees16 = _mm_maskz_loadu_epi16(lanes, a.free_count + i0);
    const __m256i views = _mm256_cvtepu16_epi32(views16), frees = _mm256_cvtepu16_epi32(frees16);
    const __mmask8 settled =
        _mm256_cmpge_epi32_mask(views, sixteen) & _mm256_cmpge_epi32_mask(_mm256_add_epi32(frees, frees), views);
    __mmask8 live = lanes & ~settled;
    if (!live) continue;
    const __m512d bz = _mm512_add_pd(_mm512_set1_pd(double(a.bz0 + i0)), zi);  // exact integers
    const __m512d z = _mm512_sub_pd(_mm512_mul_pd(_mm512_add_pd(_mm512_mul_pd(bz, eight), c35), h), tz);
    __m512d c[3];
    for (int r = 0; r < 3; ++r) {
      const __m512d a0 = _mm512_mul_pd(R[r][0], x), a1 = _mm512_mul_pd(R[r][1], y), a2 = _mm512_mul_pd(R[r][2], z);
      c[r] = r < 2 ? _mm512_add_pd(_mm512_add_pd(a0, a1), a2) : _mm512_add_pd(a0, _mm512_add_pd(a1, a2));
    }
    live &= _mm512_cmp_pd_mask(c[2], eps, _CMP_NLE_UQ);
    if (!live) continue;
    const __m512d fu = _mm512_add_pd(_mm512_add_pd(_mm512_div_pd(_mm512_mul_pd(fx, c[0]), c[2]), cx), half);
    const __m512d fv = _mm512_add_pd(_mm512_add_pd(_mm512_div_pd(_mm512_mul_pd(fy, c[1]), c[2]), cy), half);
    const int floor_mode = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
    const __m256i iu = _mm512_maskz_cvttpd_epi32(0xff, _mm512_maskz_roundscale_pd(0xff, fu, floor_mode));
    const __m256i iv = _mm512_maskz_cvttpd_epi32(0xff, _mm512_maskz_roundscale_pd(0xff, fv, floor_mode));
    live &= _mm256_cmpge_epi32_mask(iu, zero) & _mm256_cmpge_epi32_mask(iv, zero) & _mm256_cmplt_epi32_mask(iu, W) &
            _mm256_cmplt_epi32_mask(iv, H);
    if (!live) continue;
    const __m128i views_new = _mm_mask_adds_epu16(views16, live, views16, one16);
    _mm_mask_storeu_epi16(a.view_count + i0, lanes, views_new);
    const __m256i pix = _mm256_add_epi32(_mm256_mullo_epi32(iv, W), iu);
    const __m256 d = _mm256_mmask_i32gather_ps(_mm256_setzero_ps(), live, pix, a.code, 4);
    live &= _mm256_cmp_ps_mask(d, d, _CMP_ORD_Q);
    const __m512d len2 =
        _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(c[0], c[0]), _mm512_mul_pd(c[1], c[1])), _mm512_mul_pd(c[2], c[2]));
    const __m512d lambda = _mm512_div_pd(_mm512_maskz_sqrt_pd(0xff, len2), c[2]);
    const __m512d ad = _mm512_maskz_cvtps_pd(
        0xff, _mm256_castsi256_ps(_mm256_and_si256(_mm256_castps_si256(d), _mm256_set1_epi32(0x7fffffff))));
    const __mmask8 free_ = _mm256_cmp_ps_mask(d, _mm256_setzero_ps(), _CMP_EQ_OQ) |
                           _mm512_cmp_pd_mask(_mm512_mul_pd(_mm512_sub_pd(ad, c[2]), lambda), mu, _CMP_GT_OQ);
    const __m128i frees_new = _mm_mask_adds_epu16(frees16, live & free_, frees16, one16);
    _mm_mask_storeu_epi16(a.free_count + i0, lanes, frees_new);
  }
}
#else
void CarveRunAvx512(const CarveRun& a) { CarveRunScalar(a); }
#endif

namespace {

// Rule 2 of fusion.h in one block: observed voxels (weight >= min_weight) keep their
// value, the others take ±μ with the sign of the nearest observed voxel (multi-source
// BFS over 6-neighbours, sources in offset order: deterministic). Returns the number of
// observed voxels (0: `out` is left for rule 3).
int CompleteBlock(const FusionBlock& blk, float min_weight, float fmu, std::array<float, kBlockVoxels>& out) {
  std::array<int8_t, kBlockVoxels> sign;
  std::array<int, kBlockVoxels> queue;
  int head = 0, tail = 0;
  for (int o = 0; o < kBlockVoxels; ++o) {
    if (blk.weight[o] >= min_weight) {
      out[o] = blk.tsdf[o];
      sign[o] = blk.tsdf[o] < 0 ? -1 : 1;
      queue[tail++] = o;
    } else {
      sign[o] = 0;
    }
  }
  const int observed = tail;
  if (observed == 0) return 0;
  while (head < tail) {
    const int o = queue[head++];
    const int x = o >> 6, y = (o >> 3) & 7, z = o & 7;
    const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z}, {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
    for (const auto& n : nb) {
      if (n[0] < 0 || n[1] < 0 || n[2] < 0 || n[0] > 7 || n[1] > 7 || n[2] > 7) continue;
      const int q = LocalOffset(n[0], n[1], n[2]);
      if (sign[q] != 0) continue;
      sign[q] = sign[o];
      out[q] = sign[o] * fmu;
      queue[tail++] = q;
    }
  }
  return observed;
}

}  // namespace

void Tsdf::Impl::EnsureComplete() const {
  if (!dirty.load(std::memory_order_acquire)) return;
  std::lock_guard<std::mutex> lock(complete_mutex);
  if (!dirty.load(std::memory_order_relaxed)) return;
  const float fmu = float(mu);
  const float min_weight = float(std::max(1, opt.min_weight));
  completed.resize(blocks.size());
  has_observed.assign(blocks.size(), 0);
  observed_voxels = 0;
  Eigen::Vector3i hull_lo = Eigen::Vector3i::Constant(std::numeric_limits<int>::max());
  Eigen::Vector3i hull_hi = Eigen::Vector3i::Constant(std::numeric_limits<int>::min());
  // Rule 2 (CompleteBlock); blocks are independent: chunks of them in parallel.
  constexpr int kChunk = 64;
  const int nblocks = static_cast<int>(blocks.size());
  const int chunks = (nblocks + kChunk - 1) / kChunk;
  struct ChunkResult {
    int observed = 0;
    Eigen::Vector3i lo = Eigen::Vector3i::Constant(std::numeric_limits<int>::max());
    Eigen::Vector3i hi = Eigen::Vector3i::Constant(std::numeric_limits<int>::min());
  };
  std::vector<ChunkResult> chunk_results(chunks);
  ParallelFor(chunks, opt.threads, [&](int c) {
    ChunkResult& res = chunk_results[c];
    for (int bi = c * kChunk; bi < std::min(nblocks, (c + 1) * kChunk); ++bi) {
      const FusionBlock& blk = *blocks[bi];
      const int observed = CompleteBlock(blk, min_weight, fmu, completed[bi]);
      res.observed += observed;
      if (observed == 0) continue;
      has_observed[bi] = 1;
      res.lo = res.lo.cwiseMin(blk.coord);
      res.hi = res.hi.cwiseMax(blk.coord);
    }
  });
  for (const ChunkResult& r : chunk_results) {
    observed_voxels += r.observed;
    hull_lo = hull_lo.cwiseMin(r.lo);
    hull_hi = hull_hi.cwiseMax(r.hi);
  }
  // Rule 3: block-level carving for blocks without observed voxels.
  inside.assign(free_count.size(), 0);
  inside_blocks = 0;
  for (int bx = 0; bx < carve_dims.x(); ++bx) {
    for (int by = 0; by < carve_dims.y(); ++by) {
      for (int bz = 0; bz < carve_dims.z(); ++bz) {
        const size_t ci = (size_t(bx) * carve_dims.y() + by) * carve_dims.z() + bz;
        if (view_count[ci] == 0 ||
            (free_count[ci] >= opt.carve_min_views && free_count[ci] >= opt.carve_min_fraction * view_count[ci]))
          continue;
        const Eigen::Vector3i b = carve_lo + Eigen::Vector3i(bx, by, bz);
        if ((b.array() < hull_lo.array()).any() || (b.array() > hull_hi.array()).any()) continue;
        const int bi = FindBlock(b);
        if (bi >= 0 && has_observed[bi]) continue;
        inside[ci] = 1;
        ++inside_blocks;
      }
    }
  }
  // Blocks allocated but never observed take their carving state everywhere.
  for (size_t bi = 0; bi < blocks.size(); ++bi) {
    if (has_observed[bi]) continue;
    const int ci = CarveIndex(blocks[bi]->coord);
    completed[bi].fill(ci >= 0 && inside[ci] ? -fmu : fmu);
  }
  dirty.store(false, std::memory_order_release);
}

float Tsdf::Impl::VoxelValue(const Eigen::Vector3i& ijk) const {
  const Eigen::Vector3i b(FloorDiv8(ijk.x()), FloorDiv8(ijk.y()), FloorDiv8(ijk.z()));
  const int bi = FindBlock(b);
  if (bi >= 0) {
    const Eigen::Vector3i l = ijk - b * kBlockDim;
    return completed[bi][LocalOffset(l.x(), l.y(), l.z())];
  }
  const int ci = CarveIndex(b);
  return ci >= 0 && inside[ci] ? -float(mu) : float(mu);
}

double Tsdf::Sdf(const Vec3& p) const {
  const Impl& m = *impl_;
  m.EnsureComplete();
  const Vec3 g = p / m.h;
  if (!g.allFinite() || (g.array().abs() > 1e6).any()) return m.mu;
  const Eigen::Vector3i i0(static_cast<int>(std::floor(g.x())), static_cast<int>(std::floor(g.y())),
                           static_cast<int>(std::floor(g.z())));
  const Vec3 f = g - i0.cast<double>();
  double value = 0;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3i o(c >> 2, (c >> 1) & 1, c & 1);
    const double w = (o.x() ? f.x() : 1 - f.x()) * (o.y() ? f.y() : 1 - f.y()) * (o.z() ? f.z() : 1 - f.z());
    if (w == 0) continue;
    value += w * m.VoxelValue(i0 + o);
  }
  return value;
}

double Tsdf::Weight(const Vec3& p) const {
  const Impl& m = *impl_;
  const Vec3 g = p / m.h;
  if (!g.allFinite() || (g.array().abs() > 1e6).any()) return 0;
  const Eigen::Vector3i ijk(static_cast<int>(std::floor(g.x() + 0.5)), static_cast<int>(std::floor(g.y() + 0.5)),
                            static_cast<int>(std::floor(g.z() + 0.5)));
  const Eigen::Vector3i b(FloorDiv8(ijk.x()), FloorDiv8(ijk.y()), FloorDiv8(ijk.z()));
  const int bi = m.FindBlock(b);
  if (bi < 0) return 0;
  const Eigen::Vector3i l = ijk - b * kBlockDim;
  return m.blocks[bi]->weight[LocalOffset(l.x(), l.y(), l.z())];
}

namespace {

// Tsdf::SurfacePoints' scan: the field's zero crossings along voxel edges, block by block.
class SurfaceScan {
 public:
  // A block's values: allocated (its completed values), unobserved interior (-μ), or
  // elsewhere +μ; active = allocated or interior.
  struct BlockValues {
    const float* values = nullptr;
    float constant = 0;
    bool active = false;
  };

  explicit SurfaceScan(const Tsdf::Impl& m) : m_(m), fmu_(float(m.mu)) {}

  BlockValues Values(const Eigen::Vector3i& b) const {
    const int bi = m_.FindBlock(b);
    if (bi >= 0) return {m_.completed[bi].data(), 0.f, true};
    const int ci = m_.CarveIndex(b);
    const bool in = ci >= 0 && m_.inside[ci];
    return {nullptr, in ? -fmu_ : fmu_, in};
  }

  // Each edge (a, a + e) belongs to a's block if that is active, else to the other end's.
  void Block(const Eigen::Vector3i& b, const BlockValues& self) {
    constexpr int kStride[3] = {64, 8, 1};  // LocalOffset steps along x, y, z
    const Eigen::Vector3i base = b * kBlockDim;
    BlockValues high[3];
    bool low_free[3];
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3i nb = b;
      nb[axis] += 1;
      high[axis] = Values(nb);
      nb[axis] -= 2;
      low_free[axis] = !Values(nb).active;
    }
    const bool uniform = Uniform(self);
    for (int o = 0; o < kBlockVoxels; ++o) {
      const int l[3] = {o >> 6, (o >> 3) & 7, o & 7};
      const bool face = l[0] == 0 || l[1] == 0 || l[2] == 0 || l[0] == kBlockDim - 1 || l[1] == kBlockDim - 1 ||
                        l[2] == kBlockDim - 1;
      if (uniform && !face) continue;
      const float v = self.values ? self.values[o] : self.constant;
      for (int axis = 0; axis < 3; ++axis) {
        const bool is_high = l[axis] == kBlockDim - 1, is_low = l[axis] == 0 && low_free[axis];
        if (uniform && !is_high && !is_low) continue;
        const Eigen::Vector3i a = base + Eigen::Vector3i(l[0], l[1], l[2]);
        if (!is_high) {
          if (self.values) Edge(a, v, axis, self.values[o + kStride[axis]]);
        } else {
          const BlockValues& n = high[axis];
          Edge(a, v, axis, n.values ? n.values[o - (kBlockDim - 1) * kStride[axis]] : n.constant);
        }
        if (is_low) {
          Eigen::Vector3i p = a;
          p[axis] -= 1;
          Edge(p, fmu_, axis, v);
        }
      }
    }
  }

  std::vector<Vec3> points;

 private:
  // A block of one sign (free space, deep inside, interior blocks) can only cross at
  // its faces.
  static bool Uniform(const BlockValues& self) {
    if (!self.values) return true;
    int negative = 0;
    for (int o = 0; o < kBlockVoxels; ++o) negative += self.values[o] < 0;
    return negative == 0 || negative == kBlockVoxels;
  }
  void Edge(const Eigen::Vector3i& a, float va, int axis, float vb) {
    if ((va < 0) == (vb < 0)) return;
    Vec3 p = a.cast<double>();
    p[axis] += double(va) / (double(va) - double(vb));
    points.push_back(p * m_.h);
  }

  const Tsdf::Impl& m_;
  const float fmu_;
};

}  // namespace

Points3 Tsdf::SurfacePoints() const {
  const Impl& m = *impl_;
  m.EnsureComplete();
  // Chunks of blocks in parallel, their points concatenated in block order.
  constexpr int kChunk = 64;
  const int nblocks = static_cast<int>(m.blocks.size());
  std::vector<std::vector<Vec3>> chunk_points((nblocks + kChunk - 1) / kChunk);
  ParallelFor(static_cast<int>(chunk_points.size()), m.opt.threads, [&](int c) {
    SurfaceScan chunk(m);
    for (int bi = c * kChunk; bi < std::min(nblocks, (c + 1) * kChunk); ++bi)
      chunk.Block(m.blocks[bi]->coord, {m.completed[bi].data(), 0.f, true});
    chunk_points[c] = std::move(chunk.points);
  });
  SurfaceScan scan(m);
  for (auto& pts : chunk_points) scan.points.insert(scan.points.end(), pts.begin(), pts.end());
  for (int bx = 0; bx < m.carve_dims.x(); ++bx)
    for (int by = 0; by < m.carve_dims.y(); ++by)
      for (int bz = 0; bz < m.carve_dims.z(); ++bz) {
        const size_t ci = (size_t(bx) * m.carve_dims.y() + by) * m.carve_dims.z() + bz;
        if (!m.inside[ci]) continue;
        const Eigen::Vector3i b = m.carve_lo + Eigen::Vector3i(bx, by, bz);
        if (m.FindBlock(b) < 0) scan.Block(b, {nullptr, -float(m.mu), true});
      }
  const std::vector<Vec3>& pts = scan.points;
  Points3 P(pts.size(), 3);
  for (size_t i = 0; i < pts.size(); ++i) P.row(i) = pts[i].transpose();
  return P;
}

FusionStats Tsdf::Stats() const {
  const Impl& m = *impl_;
  m.EnsureComplete();
  FusionStats s;
  s.frames_integrated = m.frames;
  s.foreground_pixels = m.foreground_pixels;
  s.voxel_updates = m.voxel_updates;
  s.surface_blocks = static_cast<int>(m.blocks.size());
  s.observed_voxels = m.observed_voxels;
  s.inside_blocks = m.inside_blocks;
  s.steps = {m.times.segment, m.times.dropouts, m.times.allocate, m.times.update, m.times.carve};
  s.steps_cpu = m.times_cpu;
  return s;
}

FusionResult FuseFrames(const std::vector<DepthFrame>& frames, const Intrinsics& intrinsics,
                        const FusionOptions& options, uint64_t seed, bool extract_mesh) {
  options.Validate();
  const auto start = Clock::now();
  FusionResult result;
  result.tsdf = std::make_shared<Tsdf>(options);
  const uint64_t pose_seed = DeriveSeed(seed, "fusion/pose");
  std::vector<Tsdf::Impl::FrameInput> inputs;
  for (size_t i = 0; i < frames.size(); i += options.frames_stride) {
    Eigen::Isometry3d pose = frames[i].camera_to_object;
    if (options.pose_noise_degrees > 0) {
      // One stream per frame index, so the stride does not change a frame's error.
      Rng rng(DeriveSeed(pose_seed, std::to_string(i)));
      const double delta = rng.Normal(0, options.pose_noise_degrees * M_PI / 180);
      pose = Eigen::Isometry3d(Eigen::AngleAxisd(delta, Vec3::UnitY())) * pose;
    }
    try {
      CheckFrame(frames[i].depth, intrinsics);
    } catch (const Error& e) {
      throw Error("frame " + std::to_string(i) + ": " + e.what());
    }
    inputs.push_back({frames[i].depth.data(), pose});
  }
  result.tsdf->impl_->IntegrateBatch(inputs, intrinsics);
  if (extract_mesh) result.mesh = result.tsdf->ExtractMesh();
  result.stats = result.tsdf->Stats();
  result.stats.mesh_vertices = result.mesh.NumVertices();
  result.stats.mesh_faces = result.mesh.NumFaces();
  result.stats.wall_seconds = Since(start);
  return result;
}

}  // namespace drape
