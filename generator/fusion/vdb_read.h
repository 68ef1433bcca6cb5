// Reading back a release's sdf.vdb (what Tsdf::EncodeVdb writes): for the Python
// package, feature extraction from a stored volume, and tools that want a dense array.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <vector>

#include "common/mesh.h"

namespace drape {

// A dense copy of the "sdf" and "weight" grids over the bounding box of every leaf and
// non-background tile of the sdf grid. Element (a, b, c) is voxel index origin + (a, b, c)
// at object-frame point (origin + (a, b, c)) · voxel_size (metres); x-major storage:
// values[(a · dims.y + b) · dims.z + c]. Outside the box the field is +truncation.
struct DenseSdf {
  Eigen::Vector3i origin = Eigen::Vector3i::Zero();  // voxel index of element (0, 0, 0)
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();    // elements along x, y, z
  double voxel_size = 0;                             // metres
  double truncation = 0;                             // metres (the sdf grid's background)
  std::vector<float> sdf;                            // metres, < 0 inside
  std::vector<float> weight;                         // fusion observations, 0 = unobserved
  // 4×4 voxel index (a, b, c, 1) → object-frame point (metres).
  Eigen::Matrix4d IndexToObject() const;
};

// Tsdf::SurfacePoints on a dense copy (every edge of the box, brute force; the field is
// +truncation outside it, so no crossing is missed): the same points, in x-major edge order.
Points3 DenseSurfacePoints(const DenseSdf& d);

// The sdf grid of a .vdb file. Cheap to copy (shared, immutable); Sample is thread-safe.
class SdfGrid {
 public:
  // Throws drape::Error naming the file if it is unreadable or holds no float grid "sdf".
  static SdfGrid Read(const std::filesystem::path& path);
  // Trilinear value at p (object frame, metres) by OpenVDB's BoxSampler, voxel centres at
  // integer multiples of the voxel size (as Tsdf::Sdf).
  double Sample(const Vec3& p) const;
  double voxel_size() const;
  DenseSdf Dense() const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

}  // namespace drape
