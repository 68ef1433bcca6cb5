// The straightforward integration path, kept to test the fast one against (same
// values bit for bit): whole-image segmentation, a pixel flood fill for the enclosed
// dropouts, the scalar voxel update, and carving over the whole box.
#include <algorithm>
#include <cmath>
#include <limits>

#include "common/parallel.h"
#include "generator/fusion/tsdf_impl.h"

namespace drape {

namespace {

// code (see FrameScratch) over the whole image; returns the foreground count.
int64_t SegmentWholeImage(const Tsdf::Impl& m, const std::vector<float>& depth, const FrameView& view,
                          std::vector<float>& code, std::vector<uint8_t>& fg) {
  const int W = view.W, H = view.H;
  const double radius2 = m.opt.radius > 0 ? m.opt.radius * m.opt.radius : 0;
  code.assign(size_t(W) * H, 0.f);
  fg.assign(size_t(W) * H, 0);
  int64_t fg_count = 0;
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = size_t(v) * W + u;
      const float d = depth[i];
      if (!(d > 0) || !std::isfinite(d)) continue;
      const Vec3 p = view.R * Vec3(d * m.xhat[u], d * m.yhat[v], d) + view.t;
      if (m.opt.box.contains(p) && (radius2 <= 0 || p.x() * p.x() + p.z() * p.z() <= radius2)) {
        code[i] = d;
        fg[i] = 1;
        ++fg_count;
      } else {
        code[i] = -d;
      }
    }
  }
  return fg_count;
}

// No-data pixels not connected to the image border through non-foreground pixels,
// or within hole_radius_px of a foreground pixel, become NaN (ignored).
void MarkDropoutsWholeImage(const Tsdf::Impl& m, const FrameView& view, std::vector<float>& code,
                            const std::vector<uint8_t>& fg) {
  const int W = view.W, H = view.H;
  std::vector<uint8_t> outside(size_t(W) * H, 0);
  std::vector<int> queue;
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
  const int r = m.opt.hole_radius_px;
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t i = size_t(v) * W + u;
      if (code[i] != 0) continue;
      bool near = false;
      for (int dv = -r; dv <= r && !near; ++dv)
        for (int du = -r; du <= r && !near; ++du) {
          const int uu = u + du, vv = v + dv;
          near = uu >= 0 && vv >= 0 && uu < W && vv < H && fg[size_t(vv) * W + uu];
        }
      if (near) code[i] = std::numeric_limits<float>::quiet_NaN();
    }
  }
}

void CarveWholeBox(Tsdf::Impl& m, const FrameView& view, const std::vector<float>& code) {
  const int cap = std::numeric_limits<uint16_t>::max();
  const Eigen::Vector3i& dims = m.carve_dims;
  const double h = m.h;
  for (int bx = 0; bx < dims.x(); ++bx) {
    for (int by = 0; by < dims.y(); ++by) {
      for (int bz = 0; bz < dims.z(); ++bz) {
        const size_t ci = (size_t(bx) * dims.y() + by) * dims.z() + bz;
        if (m.view_count[ci] >= 16 && 2 * m.free_count[ci] >= m.view_count[ci]) continue;
        const Eigen::Vector3i b = m.carve_lo + Eigen::Vector3i(bx, by, bz);
        const Vec3 p = (b.cast<double>() * kBlockDim + Vec3::Constant(3.5)) * h;
        const Vec3 c = view.Rt * (p - view.t);
        if (c.z() <= 1e-6) continue;
        const int iu = static_cast<int>(std::floor(view.K.fx * c.x() / c.z() + view.K.cx + 0.5));
        const int iv = static_cast<int>(std::floor(view.K.fy * c.y() / c.z() + view.K.cy + 0.5));
        if (iu < 0 || iv < 0 || iu >= view.W || iv >= view.H) continue;
        if (m.view_count[ci] < cap) ++m.view_count[ci];
        const float d = code[size_t(iv) * view.W + iu];
        if (std::isnan(d)) continue;
        const double lambda = c.norm() / c.z();
        const bool free = d == 0 || (std::abs(d) - c.z()) * lambda > m.mu;
        if (free && m.free_count[ci] < cap) ++m.free_count[ci];
      }
    }
  }
}

}  // namespace

// The blocks that the band [d - μ, d + μ] of each foreground pixel crosses (the
// sampling of BandBlocks, std::floor for the voxel), allocated on first sight; each
// block listed once per frame (its stamp), at its first sample.
std::vector<int> Tsdf::Impl::AllocateBand(const FrameView& view, const std::vector<float>& code, int stamp) {
  std::vector<int> touched;
  float far = 0;
  for (int v = 0; v < view.H; ++v)
    for (int u = 0; u < view.W; ++u) far = std::max(far, std::max(code[size_t(v) * view.W + u], 0.f));
  const double block_px = far > 0 ? kBlockDim * h * std::min(view.K.fx, view.K.fy) / far : 1;
  const int stride = std::clamp(static_cast<int>(block_px / 3), 1, 8);
  const int steps = static_cast<int>(std::ceil(2 * mu / (0.5 * kBlockDim * h)));
  for (int v = 0; v < view.H; v += stride) {
    for (int u = 0; u < view.W; u += stride) {
      const float d = code[size_t(v) * view.W + u];
      if (!(d > 0)) continue;
      const double lambda = std::sqrt(1 + xhat[u] * xhat[u] + yhat[v] * yhat[v]);
      const Vec3 ray = view.R * Vec3(xhat[u], yhat[v], 1.0);
      for (int s = 0; s <= steps; ++s) {
        const double along = -mu + 2 * mu * s / steps;  // metres along the ray
        const double z = d + along / lambda;
        if (z <= 0) continue;
        const Vec3 p = z * ray + view.t;
        const Eigen::Vector3i b(FloorDiv8(static_cast<int>(std::floor(p.x() / h + 0.5))),
                                FloorDiv8(static_cast<int>(std::floor(p.y() / h + 0.5))),
                                FloorDiv8(static_cast<int>(std::floor(p.z() / h + 0.5))));
        FusionBlock& blk = *blocks[FindOrCreateBlock(b)];
        if (blk.stamp != stamp) {
          blk.stamp = stamp;
          touched.push_back(FindBlock(b));
        }
      }
    }
  }
  return touched;
}

void Tsdf::Impl::IntegrateReference(const std::vector<float>& depth, const Eigen::Isometry3d& pose,
                                    const Intrinsics& K) {
  UpdateRays(K);
  FrameView view = MakeView(pose, K);
  view.u0 = view.v0 = 0, view.u1 = view.W, view.v1 = view.H;
  std::vector<float> code;
  std::vector<uint8_t> fg;
  const int64_t fg_count = SegmentWholeImage(*this, depth, view, code, fg);
  if (fg_count > 0) MarkDropoutsWholeImage(*this, view, code, fg);
  const std::vector<int> touched = AllocateBand(view, code, frames);
  for (int bi : touched) {
    FusionBlock& blk = *blocks[bi];
    voxel_updates += UpdateBlockScalar(blk, ProjectorFor(view, blk.coord, h, mu), code.data());
  }
  CarveWholeBox(*this, view, code);
  foreground_pixels += fg_count;
  ++frames;
  dirty.store(true);
}

}  // namespace drape
