// Internal: the sparse block volume behind Tsdf, shared by tsdf.cpp (integration,
// queries; no OpenVDB) and vdb.cpp (OpenVDB meshing and .vdb export).
#pragma once

#include <array>
#include <atomic>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "generator/fusion/fusion.h"

namespace drape {

// 8³ voxels, the size of an OpenVDB leaf; voxel offset (x<<6)|(y<<3)|z like a leaf's.
constexpr int kBlockDim = 8;
constexpr int kBlockVoxels = kBlockDim * kBlockDim * kBlockDim;

struct FusionBlock {
  Eigen::Vector3i coord;  // block coordinate; voxel index = coord*8 + local
  std::array<float, kBlockVoxels> tsdf;
  std::array<float, kBlockVoxels> weight;
  int stamp = -1;  // last frame that touched it
};

inline int LocalOffset(int x, int y, int z) { return (x << 6) | (y << 3) | z; }

struct Tsdf::Impl {
  FusionOptions opt;
  double h = 0, mu = 0;

  std::unordered_map<uint64_t, int> index;  // packed block coord → blocks[i]
  std::vector<std::unique_ptr<FusionBlock>> blocks;

  // Block-level carving grid over the segmentation box.
  Eigen::Vector3i carve_lo{0, 0, 0}, carve_dims{0, 0, 0};
  std::vector<uint16_t> free_count, view_count;

  int frames = 0;
  int64_t foreground_pixels = 0, voxel_updates = 0;

  // Cached ray directions for the last intrinsics.
  Intrinsics rays_for{};
  std::vector<double> xhat, yhat;
  bool rays_valid = false;

  // Completion (rules 2 and 3 of fusion.h), computed lazily after integration.
  mutable std::mutex complete_mutex;
  mutable std::atomic<bool> dirty{true};
  mutable std::vector<std::array<float, kBlockVoxels>> completed;  // per block
  mutable std::vector<uint8_t> has_observed;                        // per block
  mutable std::vector<uint8_t> inside;                              // per carve cell
  mutable int inside_blocks = 0, observed_voxels = 0;

  static uint64_t Key(const Eigen::Vector3i& b) {
    constexpr int64_t kOff = int64_t(1) << 20;
    return (uint64_t(b.x() + kOff) << 42) | (uint64_t(b.y() + kOff) << 21) | uint64_t(b.z() + kOff);
  }
  int CarveIndex(const Eigen::Vector3i& b) const {
    const Eigen::Vector3i r = b - carve_lo;
    if ((r.array() < 0).any() || (r.array() >= carve_dims.array()).any()) return -1;
    return (r.x() * carve_dims.y() + r.y()) * carve_dims.z() + r.z();
  }
  int FindBlock(const Eigen::Vector3i& b) const {
    auto it = index.find(Key(b));
    return it == index.end() ? -1 : it->second;
  }

  void EnsureComplete() const;
  // Completed value (metres) of voxel ijk.
  float VoxelValue(const Eigen::Vector3i& ijk) const;
};

inline int FloorDiv8(int v) { return v >= 0 ? v / 8 : -((-v + 7) / 8); }

}  // namespace drape
