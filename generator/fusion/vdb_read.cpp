// OpenVDB reading only (no tools/ meshing headers, to keep this translation unit light).
#include "generator/fusion/vdb_read.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <mutex>
#include <optional>

#include "common/error.h"

namespace drape {

struct SdfGrid::Impl {
  openvdb::FloatGrid::ConstPtr sdf, weight;
  double h = 0;
};

SdfGrid SdfGrid::Read(const std::filesystem::path& path) {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
  if (!std::filesystem::is_regular_file(path)) throw Error(path.string() + ": no such file");
  auto impl = std::make_shared<Impl>();
  try {
    openvdb::io::File file(path.string());
    file.open(false);  // no delayed loading: the file may go away
    for (const char* name : {"sdf", "weight"}) {
      if (!file.hasGrid(name)) continue;
      auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(name));
      if (!g) throw Error(path.string() + ": grid '" + name + "' is not a float grid");
      (std::string(name) == "sdf" ? impl->sdf : impl->weight) = g;
    }
    file.close();
  } catch (const openvdb::Exception& e) {
    throw Error(path.string() + ": not a readable .vdb file (" + e.what() + ")");
  }
  if (!impl->sdf) throw Error(path.string() + ": no float grid named 'sdf'");
  const openvdb::Vec3d vs = impl->sdf->voxelSize();
  if (!impl->sdf->transform().isLinear() || vs.x() != vs.y() || vs.y() != vs.z() || !(vs.x() > 0))
    throw Error(path.string() + ": the sdf grid's transform is not a uniform scale");
  impl->h = vs.x();
  SdfGrid out;
  out.impl_ = std::move(impl);
  return out;
}

double SdfGrid::Sample(const Vec3& p) const {
  const openvdb::Vec3d ip = impl_->sdf->transform().worldToIndex(openvdb::Vec3d(p.x(), p.y(), p.z()));
  return openvdb::tools::BoxSampler::sample(impl_->sdf->tree(), ip);
}

double SdfGrid::voxel_size() const { return impl_->h; }

Eigen::Matrix4d DenseSdf::IndexToObject() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity() * voxel_size;
  m(3, 3) = 1;
  m.block<3, 1>(0, 3) = origin.cast<double>() * voxel_size;
  return m;
}

DenseSdf SdfGrid::Dense() const {
  const auto& tree = impl_->sdf->tree();
  const float background = tree.background();
  openvdb::CoordBBox box;
  for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) box.expand(leaf->getNodeBoundingBox());
  for (auto it = tree.cbeginValueAll(); it; ++it) {
    if (it.isVoxelValue() || *it == background) continue;  // leaves counted above
    openvdb::CoordBBox b;
    it.getBoundingBox(b);
    box.expand(b);
  }
  DenseSdf d;
  d.voxel_size = impl_->h;
  d.truncation = background;
  if (box.empty()) return d;
  d.origin = Eigen::Vector3i(box.min().x(), box.min().y(), box.min().z());
  const openvdb::Coord dim = box.dim();
  d.dims = Eigen::Vector3i(dim.x(), dim.y(), dim.z());
  const size_t n = size_t(dim.x()) * dim.y() * dim.z();
  d.sdf.resize(n);
  d.weight.assign(n, 0.f);
  auto sdf = impl_->sdf->getConstAccessor();
  std::optional<openvdb::FloatGrid::ConstAccessor> weight;
  if (impl_->weight) weight.emplace(impl_->weight->getConstAccessor());
  size_t i = 0;
  for (int a = 0; a < dim.x(); ++a)
    for (int b = 0; b < dim.y(); ++b)
      for (int c = 0; c < dim.z(); ++c, ++i) {
        const openvdb::Coord ijk = box.min().offsetBy(a, b, c);
        d.sdf[i] = sdf.getValue(ijk);
        if (weight) d.weight[i] = weight->getValue(ijk);
      }
  return d;
}

Points3 DenseSurfacePoints(const DenseSdf& d) {
  std::vector<Vec3> pts;
  auto at = [&](int a, int b, int c) -> float {
    if (a < 0 || b < 0 || c < 0 || a >= d.dims.x() || b >= d.dims.y() || c >= d.dims.z()) return float(d.truncation);
    return d.sdf[(size_t(a) * d.dims.y() + b) * d.dims.z() + c];
  };
  // Every edge with an end in the box, from one voxel before it to the last voxel.
  for (int a = -1; a < d.dims.x(); ++a)
    for (int b = -1; b < d.dims.y(); ++b)
      for (int c = -1; c < d.dims.z(); ++c) {
        const float v = at(a, b, c);
        for (int axis = 0; axis < 3; ++axis) {
          const int n[3] = {a + (axis == 0), b + (axis == 1), c + (axis == 2)};
          const float w = at(n[0], n[1], n[2]);
          if ((v < 0) == (w < 0)) continue;
          Vec3 p(d.origin.x() + a, d.origin.y() + b, d.origin.z() + c);
          p[axis] += double(v) / (double(v) - double(w));
          pts.push_back(p * d.voxel_size);
        }
      }
  Points3 P(pts.size(), 3);
  for (size_t i = 0; i < pts.size(); ++i) P.row(i) = pts[i].transpose();
  return P;
}

}  // namespace drape
