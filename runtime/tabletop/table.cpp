#include "runtime/tabletop/table.h"

#include <cmath>

#include "common/error.h"
#include "garments/render.h"

namespace drape::tabletop {

void TableOptions::Validate() const {
  if (!std::isfinite(top)) throw Error("TableOptions.top must be finite");
  if (!(half_x > 0 && half_z > 0)) throw Error("TableOptions.half_x/half_z must be > 0");
  if (!(thickness > 0)) throw Error("TableOptions.thickness must be > 0");
  if (!(clearance >= 0 && clearance < 0.1)) throw Error("TableOptions.clearance must be in [0, 0.1) m");
}

Points3 LayFlat(const TriMesh& flat, const TableOptions& table, const Vec2& offset, double yaw) {
  table.Validate();
  if (flat.NumVertices() == 0) throw Error("LayFlat: empty mesh");
  const Vec3 lo = flat.V.colwise().minCoeff(), hi = flat.V.colwise().maxCoeff();
  const Vec3 mid = 0.5 * (lo + hi);
  const double c = std::cos(yaw), s = std::sin(yaw);
  Points3 out(flat.NumVertices(), 3);
  for (int i = 0; i < flat.NumVertices(); ++i) {
    const double px = flat.V(i, 0) - mid.x(), pz = -(flat.V(i, 1) - mid.y());
    // Rotation about +y by yaw: (x, z) → (c·x + s·z, −s·x + c·z).
    out(i, 0) = offset.x() + c * px + s * pz;
    out(i, 2) = offset.y() - s * px + c * pz;
    out(i, 1) = table.top + table.clearance + (flat.V(i, 2) - lo.z());
  }
  return out;
}

Points3 PlaceOnTable(const Points3& lying, const TriMesh& pattern, const TableOptions& table, const Vec2& offset,
                     double yaw) {
  table.Validate();
  const int n = static_cast<int>(lying.rows());
  if (n == 0 || n != pattern.NumVertices())
    throw Error("PlaceOnTable: the lying garment has " + std::to_string(n) + " vertices, its pattern " +
                std::to_string(pattern.NumVertices()));
  if (!lying.allFinite()) throw Error("PlaceOnTable: the lying garment has a non-finite vertex");
  // Upright as LayFlat lays the pattern: (x, −y); lying: (x, z); both about their means.
  Eigen::Matrix2Xd q(2, n), p(2, n);
  q.row(0) = pattern.V.col(0).transpose();
  q.row(1) = -pattern.V.col(1).transpose();
  p.row(0) = lying.col(0).transpose();
  p.row(1) = lying.col(2).transpose();
  q.colwise() -= q.rowwise().mean();
  p.colwise() -= p.rowwise().mean();
  // lying ≈ R(θ)·upright, θ = atan2(Σ q × p, Σ q · p) (2-D Kabsch); undo it, then turn
  // by LayFlat's yaw, which is R(−yaw) in these coordinates.
  const double theta = std::atan2((q.row(0).array() * p.row(1).array() - q.row(1).array() * p.row(0).array()).sum(),
                                  (q.array() * p.array()).sum());
  const Eigen::Rotation2Dd back(-theta), turn(-yaw);
  Eigen::Matrix2Xd u(2, n);
  for (int i = 0; i < n; ++i) u.col(i) = back * Vec2(lying(i, 0), lying(i, 2));
  const Vec2 mid = 0.5 * (u.rowwise().minCoeff() + u.rowwise().maxCoeff());
  const double low = lying.col(1).minCoeff();
  Points3 out(n, 3);
  for (int i = 0; i < n; ++i) {
    const Vec2 w = offset + turn * (u.col(i) - mid);
    out.row(i) = Vec3(w.x(), table.top + table.clearance + lying(i, 1) - low, w.y()).transpose();
  }
  return out;
}

Vec2 TopDownCamera::ToWorldXZ(const Vec2& f) const {
  // The rasteriser puts pixel centres at integer coordinates; the frame at + ½.
  const double col = f.x() - 0.5, row = -f.y() - 0.5;
  return Vec2(cx + (col - width / 2.0) * metres_per_pixel, cz + (row - height / 2.0) * metres_per_pixel);
}

Vec2 TopDownCamera::ToFrame(double x, double z) const {
  return Vec2((x - cx) / metres_per_pixel + width / 2.0 + 0.5, -((z - cz) / metres_per_pixel + height / 2.0 + 0.5));
}

TopDownCamera FrameCamera(const Points3& positions, double metres_per_pixel, double margin) {
  if (!(metres_per_pixel > 0)) throw Error("FrameCamera: metres_per_pixel must be > 0");
  const Vec3 lo = positions.colwise().minCoeff(), hi = positions.colwise().maxCoeff();
  TopDownCamera cam;
  cam.metres_per_pixel = metres_per_pixel;
  cam.cx = 0.5 * (lo.x() + hi.x());
  cam.cz = 0.5 * (lo.z() + hi.z());
  cam.width = static_cast<int>(std::ceil((hi.x() - lo.x() + 2 * margin) / metres_per_pixel));
  cam.height = static_cast<int>(std::ceil((hi.z() - lo.z() + 2 * margin) / metres_per_pixel));
  return cam;
}

namespace {
// The mesh in the rasteriser's object frame (x right, y up = world −z, depth = world y).
TriMesh PictureMesh(const TriMesh& world) {
  TriMesh m;
  m.F = world.F;
  m.V.resize(world.NumVertices(), 3);
  m.V.col(0) = world.V.col(0);
  m.V.col(1) = -world.V.col(2);
  m.V.col(2) = world.V.col(1);
  return m;
}
OrthoView View(const TopDownCamera& cam) {
  OrthoView v;
  v.width = cam.width;
  v.height = cam.height;
  v.scale = 1 / cam.metres_per_pixel;
  v.cx = cam.cx;
  v.cy = -cam.cz;
  return v;
}
}  // namespace

cv::Mat TopDownPicture(const TriMesh& world_mesh, const TopDownCamera& camera, const cv::Scalar& colour) {
  cv::Mat img(camera.height, camera.width, CV_8UC3, cv::Scalar(255, 255, 255));
  DrawShadedMesh(img, PictureMesh(world_mesh), View(camera), colour);
  return img;
}

cv::Mat TopDownMask(const TriMesh& world_mesh, const TopDownCamera& camera) {
  cv::Mat img(camera.height, camera.width, CV_8UC3, cv::Scalar(0, 0, 0));
  // DrawShadedMesh's shade is at least 0.25: every face leaves non-zero pixels.
  DrawShadedMesh(img, PictureMesh(world_mesh), View(camera), cv::Scalar(255, 255, 255));
  cv::Mat gray, mask;
  cv::extractChannel(img, gray, 0);
  mask = gray > 0;
  return mask;
}

}  // namespace drape::tabletop
