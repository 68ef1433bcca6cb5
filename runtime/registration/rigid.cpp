#include "runtime/registration/rigid.h"

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "common/error.h"
#include "common/timing.h"

namespace drape::registration {

MeshFrame AreaWeightedFrame(const TriMesh& mesh) {
  const Eigen::VectorXd a = FaceAreas(mesh);
  const Points3 g = FaceCentroids(mesh);
  MeshFrame fr;
  fr.area = a.sum();
  if (!(fr.area > 0)) throw Error("registration: mesh has no surface area");
  fr.centre = (g.transpose() * a) / fr.area;
  double s = 0;
  for (int i = 0; i < g.rows(); ++i) s += a[i] * (Vec3(g.row(i)) - fr.centre).norm();
  fr.size = s / fr.area;
  return fr;
}

Points3 Similarity::Apply(const Points3& V) const {
  Points3 out(V.rows(), 3);
  for (int i = 0; i < V.rows(); ++i) out.row(i) = Apply(Vec3(V.row(i))).transpose();
  return out;
}

Similarity Similarity::After(const Similarity& first) const {
  Similarity s;
  s.scale = scale * first.scale;
  s.rotation = rotation * first.rotation;
  s.translation = scale * (rotation * first.translation) + translation;
  return s;
}

Eigen::Matrix4d Similarity::Matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = scale * rotation;
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Similarity ScaleToTarget(const MeshFrame& source, const MeshFrame& target) {
  if (!(source.size > 0)) throw Error("registration: source mesh has zero size");
  Similarity s;
  s.scale = target.size / source.size;
  s.translation = target.centre - s.scale * source.centre;
  return s;
}

void IcpOptions::Validate() const {
  if (max_iterations < 0) throw Error("IcpOptions.max_iterations must be >= 0");
  if (!(angle_tolerance >= 0)) throw Error("IcpOptions.angle_tolerance must be >= 0");
  if (!(translation_tolerance >= 0)) throw Error("IcpOptions.translation_tolerance must be >= 0");
}

Similarity Icp(Points3& V, const ClosestPointGrid& grid, const IcpOptions& options, IcpReport* report) {
  options.Validate();
  const auto t0 = Clock::now();
  const int n = static_cast<int>(V.rows());
  IcpReport rep;
  Similarity total;
  Eigen::Matrix3Xd src(3, n), dst(3, n);
  auto correspond = [&]() {
    double ss = 0;
    for (int i = 0; i < n; ++i) {
      const Vec3 v = V.row(i);
      const ClosestPoint c = options.refined_query ? grid.QueryRefined(v) : grid.Query(v);
      src.col(i) = v;
      dst.col(i) = c.point;
      ss += c.distance * c.distance;
    }
    return n > 0 ? std::sqrt(ss / n) : 0.0;
  };
  double rms = correspond();
  rep.rms_before = rms;
  for (int it = 0; it < options.max_iterations && n >= 3; ++it) {
    const Eigen::Matrix4d T = Eigen::umeyama(src, dst, /*with_scaling=*/false);
    Similarity step;
    step.rotation = T.topLeftCorner<3, 3>();
    step.translation = T.topRightCorner<3, 1>();
    V = step.Apply(V);
    total = step.After(total);
    rep.iterations = it + 1;
    rep.last_angle = Eigen::AngleAxisd(step.rotation).angle();
    rep.last_translation = step.translation.norm();
    rms = correspond();
    if (rep.last_angle < options.angle_tolerance && rep.last_translation < options.translation_tolerance) {
      rep.converged = true;
      break;
    }
  }
  rep.rms_after = rms;
  rep.seconds = Since(t0);
  if (report) *report = rep;
  return total;
}

}  // namespace drape::registration
