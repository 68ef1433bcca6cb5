// The one translation unit that includes OpenVDB's tools: meshing and .vdb export.
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <mutex>
#include <sstream>

#include "common/error.h"
#include "common/hash.h"
#include "generator/fusion/fusion.h"
#include "generator/fusion/tsdf_impl.h"

namespace drape {

namespace {

void InitOpenVdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

openvdb::Coord LeafOrigin(const Eigen::Vector3i& block) {
  return openvdb::Coord(block.x() * kBlockDim, block.y() * kBlockDim, block.z() * kBlockDim);
}

// The completed field as a level-set FloatGrid: observed voxels active; unobserved
// voxels of surface blocks inactive with ±μ; unobserved interior blocks as inactive
// -μ tiles (voxelize_inside: as leaves of active -μ voxels, which the mesher needs).
openvdb::FloatGrid::Ptr BuildSdfGrid(const Tsdf::Impl& m, bool voxelize_inside) {
  const float fmu = float(m.mu);
  auto grid = openvdb::FloatGrid::create(fmu);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(m.h));
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  grid->setName("sdf");
  auto& tree = grid->tree();
  for (size_t bi = 0; bi < m.blocks.size(); ++bi) {
    const FusionBlock& blk = *m.blocks[bi];
    auto* leaf = tree.touchLeaf(LeafOrigin(blk.coord));
    for (int o = 0; o < kBlockVoxels; ++o) {
      const float v = m.completed[bi][o];
      if (blk.weight[o] >= float(m.opt.min_weight) || voxelize_inside) {
        leaf->setValueOn(o, v);
      } else {
        leaf->setValueOff(o, v);
      }
    }
  }
  for (int bx = 0; bx < m.carve_dims.x(); ++bx) {
    for (int by = 0; by < m.carve_dims.y(); ++by) {
      for (int bz = 0; bz < m.carve_dims.z(); ++bz) {
        const size_t ci = (size_t(bx) * m.carve_dims.y() + by) * m.carve_dims.z() + bz;
        if (!m.inside[ci]) continue;
        const Eigen::Vector3i b = m.carve_lo + Eigen::Vector3i(bx, by, bz);
        if (m.FindBlock(b) >= 0) continue;  // allocated: already a leaf
        if (voxelize_inside) {
          auto* leaf = tree.touchLeaf(LeafOrigin(b));
          for (int o = 0; o < kBlockVoxels; ++o) leaf->setValueOn(o, -fmu);
        } else {
          tree.addTile(1, LeafOrigin(b), -fmu, false);
        }
      }
    }
  }
  return grid;
}

}  // namespace

TriMesh Tsdf::ExtractMesh() const {
  InitOpenVdb();
  const Impl& m = *impl_;
  m.EnsureComplete();
  TriMesh mesh;
  if (m.blocks.empty()) {
    mesh.V.resize(0, 3);
    mesh.F.resize(0, 3);
    return mesh;
  }
  auto grid = BuildSdfGrid(m, /*voxelize_inside=*/true);
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, tris, quads, 0.0, 0.0, true);
  mesh.V.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t i = 0; i < points.size(); ++i) mesh.V.row(i) = Vec3(points[i].x(), points[i].y(), points[i].z());
  mesh.F.resize(static_cast<Eigen::Index>(tris.size() + 2 * quads.size()), 3);
  // volumeToMesh winds polygons clockwise seen from outside (positive side) for a
  // negative-inside field; reverse to drape's counter-clockwise convention. Its quads
  // can collapse (a repeated corner): the triangles that repeat a vertex are dropped,
  // since they are degenerate and readers such as assimp reject them.
  Eigen::Index f = 0;
  auto add = [&](unsigned a, unsigned b, unsigned c) {
    if (a != b && b != c && a != c) mesh.F.row(f++) << int(a), int(b), int(c);
  };
  for (const auto& t : tris) add(t[0], t[2], t[1]);
  for (const auto& q : quads) {
    add(q[0], q[2], q[1]);
    add(q[0], q[3], q[2]);
  }
  mesh.F.conservativeResize(f, 3);
  return mesh;
}

std::string Tsdf::EncodeVdb() const {
  InitOpenVdb();
  const Impl& m = *impl_;
  m.EnsureComplete();
  auto sdf = BuildSdfGrid(m, /*voxelize_inside=*/false);
  auto weight = openvdb::FloatGrid::create(0.f);
  weight->setTransform(openvdb::math::Transform::createLinearTransform(m.h));
  weight->setGridClass(openvdb::GRID_UNKNOWN);
  weight->setName("weight");
  for (const auto& blk : m.blocks) {
    auto* leaf = weight->tree().touchLeaf(LeafOrigin(blk->coord));
    for (int o = 0; o < kBlockVoxels; ++o) {
      if (blk->weight[o] > 0) leaf->setValueOn(o, blk->weight[o]);
    }
  }
  weight->pruneGrid();
  sdf->insertMeta("truncation_m", openvdb::DoubleMetadata(m.mu));
  sdf->insertMeta("voxels_per_metre", openvdb::DoubleMetadata(m.opt.voxels_per_metre));
  sdf->insertMeta("frame", openvdb::StringMetadata("object: grasp point at origin, y up"));
  openvdb::GridPtrVec grids{sdf, weight};
  std::ostringstream os(std::ios::binary);
  openvdb::io::Stream(os).write(grids);
  std::string bytes = os.str();
  // Header: magic (8) + file version (4) + library version (8) + has-offsets flag (1),
  // then a random UUID as 36 ASCII characters. Replace it by one derived from the
  // content, for reproducible bytes.
  constexpr size_t kUuidAt = 21, kUuidLen = 36;
  DRAPE_CHECK(bytes.size() > kUuidAt + kUuidLen && bytes[kUuidAt + 8] == '-' && bytes[kUuidAt + 13] == '-' &&
                  bytes[kUuidAt + 18] == '-' && bytes[kUuidAt + 23] == '-',
              "unexpected .vdb header layout");
  std::string rest = bytes.substr(0, kUuidAt) + bytes.substr(kUuidAt + kUuidLen);
  const std::string hex = Sha256Hex(rest);
  std::string uuid = hex.substr(0, 8) + "-" + hex.substr(8, 4) + "-" + hex.substr(12, 4) + "-" + hex.substr(16, 4) +
                     "-" + hex.substr(20, 12);
  bytes.replace(kUuidAt, kUuidLen, uuid);
  return bytes;
}

}  // namespace drape
