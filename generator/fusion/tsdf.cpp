// TSDF integration, space carving and queries (no OpenVDB here: it lives in vdb.cpp).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <sstream>

#include "common/error.h"
#include "common/field_error.h"
#include "common/parallel.h"
#include "common/rng.h"
#include "generator/fusion/fusion.h"
#include "generator/fusion/tsdf_impl.h"

namespace drape {

namespace {

template <typename T>
[[noreturn]] void Bad(const T& field, const std::string& name, const std::string& what) {
  BadField(field, "FusionOptions." + name, what);
}

}  // namespace

void FusionOptions::Validate() const {
  if (!(voxels_per_metre >= 10 && voxels_per_metre <= 4096))
    Bad(voxels_per_metre, "voxels_per_metre", "must be in [10, 4096]");
  if (!std::isfinite(truncation) || truncation < 0) Bad(truncation, "truncation", "must be >= 0 (0 = 4 voxels)");
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
  if (carve_min_views < 1) Bad(carve_min_views, "carve_min_views", "must be >= 1");
  if (!(carve_min_fraction >= 0 && carve_min_fraction <= 1))
    Bad(carve_min_fraction, "carve_min_fraction", "must be in [0, 1]");
  if (hole_radius_px < 0 || hole_radius_px > 64) Bad(hole_radius_px, "hole_radius_px", "must be in [0, 64]");
  if (frames_stride < 1) Bad(frames_stride, "frames_stride", "must be >= 1");
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
}

Tsdf::~Tsdf() = default;

const FusionOptions& Tsdf::options() const { return impl_->opt; }

void Tsdf::Integrate(const DepthFrame& frame, const Intrinsics& K) {
  Impl& m = *impl_;
  const int W = K.width, H = K.height;
  if (W <= 0 || H <= 0 || !(K.fx > 0) || !(K.fy > 0))
    throw Error("Intrinsics: width, height, fx, fy must be positive");
  if (frame.depth.size() != size_t(W) * H) {
    std::ostringstream os;
    os << "DepthFrame.depth: " << frame.depth.size() << " values, expected " << W << "x" << H;
    throw Error(os.str());
  }
  if (!m.rays_valid || m.rays_for.width != W || m.rays_for.height != H || m.rays_for.fx != K.fx ||
      m.rays_for.fy != K.fy || m.rays_for.cx != K.cx || m.rays_for.cy != K.cy) {
    m.xhat.resize(W);
    m.yhat.resize(H);
    for (int u = 0; u < W; ++u) m.xhat[u] = (u - K.cx) / K.fx;
    for (int v = 0; v < H; ++v) m.yhat[v] = (v - K.cy) / K.fy;
    m.rays_for = K;
    m.rays_valid = true;
  }
  const int stamp = m.frames;
  const double h = m.h, mu = m.mu;
  const Eigen::Matrix3d R = frame.camera_to_object.linear();
  const Eigen::Vector3d t = frame.camera_to_object.translation();
  const Eigen::AlignedBox3d& box = m.opt.box;
  const double radius2 = m.opt.radius > 0 ? m.opt.radius * m.opt.radius : 0;

  // 1. Segmentation. code > 0: foreground depth (in the box); code < 0: -depth of a
  // point outside the box (carves free space only); 0: background without data;
  // NaN: no data next to the garment (a dropout, ignored).
  std::vector<float> code(size_t(W) * H);
  std::vector<uint8_t> fg(size_t(W) * H, 0);
  int64_t fg_count = 0;
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = size_t(v) * W + u;
      const float d = frame.depth[i];
      if (!(d > 0) || !std::isfinite(d)) {
        code[i] = 0;
        continue;
      }
      const Vec3 p = R * Vec3(d * m.xhat[u], d * m.yhat[v], d) + t;
      if (box.contains(p) && (radius2 <= 0 || p.x() * p.x() + p.z() * p.z() <= radius2)) {
        code[i] = d;
        fg[i] = 1;
        ++fg_count;
      } else {
        code[i] = -d;
      }
    }
  }
  // Pixels without data that the foreground encloses (not connected to the image
  // border through non-foreground pixels) are dropouts on the garment (grazing
  // angles, folds), not background → ignored. Without this, dropouts carve the
  // unobserved interior over a long sweep.
  if (fg_count > 0) {
    std::vector<uint8_t> outside(size_t(W) * H, 0);
    std::vector<int> queue;
    queue.reserve(size_t(W) * H / 4);
    auto push = [&](int u, int v) {
      const size_t i = size_t(v) * W + u;
      if (fg[i] || outside[i]) return;
      outside[i] = 1;
      queue.push_back(static_cast<int>(i));
    };
    for (int u = 0; u < W; ++u) push(u, 0), push(u, H - 1);
    for (int v = 0; v < H; ++v) push(0, v), push(W - 1, v);
    for (size_t head = 0; head < queue.size(); ++head) {
      const int i = queue[head], u = i % W, v = i / W;
      if (u > 0) push(u - 1, v);
      if (u + 1 < W) push(u + 1, v);
      if (v > 0) push(u, v - 1);
      if (v + 1 < H) push(u, v + 1);
    }
    for (size_t i = 0; i < code.size(); ++i)
      if (code[i] == 0 && !outside[i]) code[i] = std::numeric_limits<float>::quiet_NaN();
  }
  // Pixels without data within hole_radius_px of a foreground pixel → ignored.
  if (fg_count > 0) {
    const int r = m.opt.hole_radius_px;
    std::vector<uint8_t> near_row(size_t(W) * H, 0);
    std::vector<int> dist(std::max(W, H));
    for (int v = 0; v < H; ++v) {
      int last = -1000000;  // last foreground column
      for (int u = 0; u < W; ++u) {
        if (fg[size_t(v) * W + u]) last = u;
        dist[u] = u - last;
      }
      last = 1000000;
      for (int u = W - 1; u >= 0; --u) {
        if (fg[size_t(v) * W + u]) last = u;
        dist[u] = std::min(dist[u], last - u);
        near_row[size_t(v) * W + u] = dist[u] <= r;
      }
    }
    for (int u = 0; u < W; ++u) {
      int last = -1000000;
      for (int v = 0; v < H; ++v) {
        if (near_row[size_t(v) * W + u]) last = v;
        dist[v] = v - last;
      }
      last = 1000000;
      for (int v = H - 1; v >= 0; --v) {
        if (near_row[size_t(v) * W + u]) last = v;
        dist[v] = std::min(dist[v], last - v);
        const size_t i = size_t(v) * W + u;
        if (dist[v] <= r && code[i] == 0) code[i] = std::numeric_limits<float>::quiet_NaN();
      }
    }
  }

  // Free-space evidence: the pixel's own code (NaN = ignored). A 3×3-min version
  // (conservative at silhouettes) was tried and was worse: it leaves a one-pixel
  // rim outside every silhouette uncarved, which then reads inside.
  const std::vector<float>& carve = code;

  // 2. Allocate the blocks that the band [d - μ, d + μ] of each foreground pixel
  // crosses. Samples every half block along the ray, and every `stride` pixels with
  // stride ≤ a third of a block's footprint at the farthest foreground depth, so
  // no block the band crosses is skipped between samples.
  std::vector<int> touched;
  {
    float far = 0;
    for (size_t i = 0; i < code.size(); ++i) far = std::max(far, code[i] > 0 ? code[i] : 0.f);
    const double block_px = far > 0 ? kBlockDim * h * std::min(K.fx, K.fy) / far : 1;
    const int stride = std::clamp(static_cast<int>(block_px / 3), 1, 8);
    const int steps = static_cast<int>(std::ceil(2 * mu / (0.5 * kBlockDim * h)));
    // Direct-mapped cache of blocks already stamped this frame: most samples fall in
    // a block a neighbouring sample has just found.
    constexpr int kCache = 1024;
    std::array<uint64_t, kCache> cache;
    cache.fill(~uint64_t(0));
    for (int v = 0; v < H; v += stride) {
      for (int u = 0; u < W; u += stride) {
        const float d = code[size_t(v) * W + u];
        if (!(d > 0)) continue;
        const double lambda = std::sqrt(1 + m.xhat[u] * m.xhat[u] + m.yhat[v] * m.yhat[v]);
        const Vec3 ray = R * Vec3(m.xhat[u], m.yhat[v], 1.0);
        for (int s = 0; s <= steps; ++s) {
          const double along = -mu + 2 * mu * s / steps;  // metres along the ray
          const double z = d + along / lambda;
          if (z <= 0) continue;
          const Vec3 p = z * ray + t;
          const Eigen::Vector3i b(FloorDiv8(static_cast<int>(std::floor(p.x() / h + 0.5))),
                                  FloorDiv8(static_cast<int>(std::floor(p.y() / h + 0.5))),
                                  FloorDiv8(static_cast<int>(std::floor(p.z() / h + 0.5))));
          const uint64_t key = Impl::Key(b);
          uint64_t& slot = cache[(key * 0x9E3779B97F4A7C15ull) >> 54];
          if (slot == key) continue;
          slot = key;
          auto [it, inserted] = m.index.try_emplace(key, static_cast<int>(m.blocks.size()));
          if (inserted) {
            auto blk = std::make_unique<FusionBlock>();
            blk->coord = b;
            blk->tsdf.fill(0.f);
            blk->weight.fill(0.f);
            m.blocks.push_back(std::move(blk));
          }
          FusionBlock& blk = *m.blocks[it->second];
          if (blk.stamp != stamp) {
            blk.stamp = stamp;
            touched.push_back(it->second);
          }
        }
      }
    }
  }

  // 3. Projective TSDF update of every voxel of the touched blocks. Blocks are
  // independent, so any thread count gives the same values.
  const Eigen::Matrix3d Rt = R.transpose();
  const float fx = float(K.fx), fy = float(K.fy), cx = float(K.cx), cy = float(K.cy);
  const float fmu = float(mu);
  std::vector<int64_t> updates(touched.size(), 0);
  ParallelFor(static_cast<int>(touched.size()), m.opt.threads, [&](int ti) {
    FusionBlock& blk = *m.blocks[touched[ti]];
    const Vec3 origin = blk.coord.cast<double>() * (kBlockDim * h);
    const Eigen::Vector3f c0 = (Rt * (origin - t)).cast<float>();
    const Eigen::Vector3f ex = (Rt.col(0) * h).cast<float>(), ey = (Rt.col(1) * h).cast<float>(),
                          ez = (Rt.col(2) * h).cast<float>();
    int64_t n = 0;
    for (int x = 0; x < kBlockDim; ++x) {
      for (int y = 0; y < kBlockDim; ++y) {
        const Eigen::Vector3f cxy = c0 + float(x) * ex + float(y) * ey;
        for (int z = 0; z < kBlockDim; ++z) {
          const float cxv = cxy.x() + float(z) * ez.x(), cyv = cxy.y() + float(z) * ez.y(),
                      zc = cxy.z() + float(z) * ez.z();
          if (zc <= 1e-6f) continue;
          const float inv = 1.0f / zc;
          // Rounded to the nearest pixel; truncation is floor for the non-negative
          // values kept (std::floor is a libm call without SSE4.1).
          const float uf = fx * cxv * inv + cx + 0.5f, vf = fy * cyv * inv + cy + 0.5f;
          if (!(uf >= 0 && vf >= 0 && uf < float(W) && vf < float(H))) continue;
          const int iu = static_cast<int>(uf), iv = static_cast<int>(vf);
          const size_t pix = size_t(iv) * W + iu;
          const float d = code[pix];
          // Distance along the ray per unit of depth (computed, not looked up: one
          // image fetch per voxel is the cache-bound part).
          const float lambda = std::sqrt(cxv * cxv + cyv * cyv + zc * zc) * inv;
          float value;
          if (d > 0 && (d - zc) * lambda <= fmu) {
            const float sdf = (d - zc) * lambda;
            if (sdf < -fmu) continue;
            value = sdf;  // the band around an observed garment surface
          } else {
            // Free space in front of an observed depth (garment or scene). Pixels
            // without data carve only at block level (step 4), where a share of the
            // views is required: dropouts are too frequent over a long sweep.
            const float cd = carve[pix];
            if (!(std::abs(cd) > 0) || (std::abs(cd) - zc) * lambda <= fmu) continue;  // NaN, 0 too
            value = fmu;
          }
          const int o = LocalOffset(x, y, z);
          const float w = blk.weight[o];
          blk.tsdf[o] = (blk.tsdf[o] * w + value) / (w + 1);
          blk.weight[o] = w + 1;
          ++n;
        }
      }
    }
    updates[ti] = n;
  });
  for (int64_t n : updates) m.voxel_updates += n;

  // 4. Space carving at block resolution over the box (block centres).
  {
    const int cap = std::numeric_limits<uint16_t>::max();
    const Eigen::Vector3i& dims = m.carve_dims;
    for (int bx = 0; bx < dims.x(); ++bx) {
      for (int by = 0; by < dims.y(); ++by) {
        for (int bz = 0; bz < dims.z(); ++bz) {
          const size_t ci = (size_t(bx) * dims.y() + by) * dims.z() + bz;
          // Free in half of 16+ views: outside for good, whatever follows.
          if (m.view_count[ci] >= 16 && 2 * m.free_count[ci] >= m.view_count[ci]) continue;
          const Eigen::Vector3i b = m.carve_lo + Eigen::Vector3i(bx, by, bz);
          const Vec3 p = (b.cast<double>() * kBlockDim + Vec3::Constant(3.5)) * h;
          const Vec3 c = Rt * (p - t);
          if (c.z() <= 1e-6) continue;
          const int iu = static_cast<int>(std::floor(K.fx * c.x() / c.z() + K.cx + 0.5));
          const int iv = static_cast<int>(std::floor(K.fy * c.y() / c.z() + K.cy + 0.5));
          if (iu < 0 || iv < 0 || iu >= W || iv >= H) continue;
          if (m.view_count[ci] < cap) ++m.view_count[ci];
          const float d = carve[size_t(iv) * W + iu];
          if (std::isnan(d)) continue;
          const double lambda = c.norm() / c.z();
          const bool free = d == 0 || (std::abs(d) - c.z()) * lambda > mu;
          if (free && m.free_count[ci] < cap) ++m.free_count[ci];
        }
      }
    }
  }

  m.foreground_pixels += fg_count;
  ++m.frames;
  m.dirty.store(true);
}

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
  // Rule 2: unobserved voxels of a block take the sign of the nearest observed voxel
  // (multi-source BFS over 6-neighbours, sources in offset order: deterministic).
  std::vector<int8_t> sign(kBlockVoxels);
  std::vector<int> queue(kBlockVoxels);
  for (size_t bi = 0; bi < blocks.size(); ++bi) {
    const FusionBlock& blk = *blocks[bi];
    auto& out = completed[bi];
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
    observed_voxels += tail;
    if (tail == 0) continue;
    has_observed[bi] = 1;
    hull_lo = hull_lo.cwiseMin(blk.coord);
    hull_hi = hull_hi.cwiseMax(blk.coord);
    while (head < tail) {
      const int o = queue[head++];
      const int x = o >> 6, y = (o >> 3) & 7, z = o & 7;
      const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                            {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
      for (const auto& n : nb) {
        if (n[0] < 0 || n[1] < 0 || n[2] < 0 || n[0] > 7 || n[1] > 7 || n[2] > 7) continue;
        const int q = LocalOffset(n[0], n[1], n[2]);
        if (sign[q] != 0) continue;
        sign[q] = sign[o];
        out[q] = sign[o] * fmu;
        queue[tail++] = q;
      }
    }
  }
  // Rule 3: block-level carving for blocks without observed voxels.
  inside.assign(free_count.size(), 0);
  inside_blocks = 0;
  for (int bx = 0; bx < carve_dims.x(); ++bx) {
    for (int by = 0; by < carve_dims.y(); ++by) {
      for (int bz = 0; bz < carve_dims.z(); ++bz) {
        const size_t ci = (size_t(bx) * carve_dims.y() + by) * carve_dims.z() + bz;
        if (view_count[ci] == 0 || (free_count[ci] >= opt.carve_min_views &&
                                    free_count[ci] >= opt.carve_min_fraction * view_count[ci]))
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
    const double w = (o.x() ? f.x() : 1 - f.x()) * (o.y() ? f.y() : 1 - f.y()) *
                     (o.z() ? f.z() : 1 - f.z());
    if (w == 0) continue;
    value += w * m.VoxelValue(i0 + o);
  }
  return value;
}

double Tsdf::Weight(const Vec3& p) const {
  const Impl& m = *impl_;
  const Vec3 g = p / m.h;
  if (!g.allFinite() || (g.array().abs() > 1e6).any()) return 0;
  const Eigen::Vector3i ijk(static_cast<int>(std::floor(g.x() + 0.5)),
                            static_cast<int>(std::floor(g.y() + 0.5)),
                            static_cast<int>(std::floor(g.z() + 0.5)));
  const Eigen::Vector3i b(FloorDiv8(ijk.x()), FloorDiv8(ijk.y()), FloorDiv8(ijk.z()));
  const int bi = m.FindBlock(b);
  if (bi < 0) return 0;
  const Eigen::Vector3i l = ijk - b * kBlockDim;
  return m.blocks[bi]->weight[LocalOffset(l.x(), l.y(), l.z())];
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
  return s;
}

FusionResult FuseFrames(const std::vector<DepthFrame>& frames, const Intrinsics& intrinsics,
                        const FusionOptions& options, uint64_t seed) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  FusionResult result;
  result.tsdf = std::make_shared<Tsdf>(options);
  const uint64_t pose_seed = DeriveSeed(seed, "fusion/pose");
  for (size_t i = 0; i < frames.size(); i += options.frames_stride) {
    if (options.pose_noise_degrees > 0) {
      // One stream per frame index, so the stride does not change a frame's error.
      Rng rng(DeriveSeed(pose_seed, std::to_string(i)));
      const double delta = rng.Normal(0, options.pose_noise_degrees * M_PI / 180);
      DepthFrame f;
      f.camera_to_object =
          Eigen::Isometry3d(Eigen::AngleAxisd(delta, Vec3::UnitY())) * frames[i].camera_to_object;
      f.depth = frames[i].depth;
      result.tsdf->Integrate(f, intrinsics);
    } else {
      try {
        result.tsdf->Integrate(frames[i], intrinsics);
      } catch (const Error& e) {
        throw Error("frame " + std::to_string(i) + ": " + e.what());
      }
    }
  }
  result.mesh = result.tsdf->ExtractMesh();
  result.stats = result.tsdf->Stats();
  result.stats.mesh_vertices = result.mesh.NumVertices();
  result.stats.mesh_faces = result.mesh.NumFaces();
  result.stats.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace drape
