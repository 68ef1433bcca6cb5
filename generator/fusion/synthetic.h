// Analytic scenes ray-cast into depth frames: ground truth for fusion tests and
// benchmarks before (and independently of) the Embree sweep.
#pragma once

#include <cstdint>
#include <vector>

#include "common/camera.h"
#include "common/mesh.h"

namespace drape::synthetic {

// A closed primitive in the object frame. Sphere: radius = half.x(). Box: half
// extents `half`, rotated by `rotation` about `center`. Cylinder: axis = rotation's
// y column, radius = half.x(), half height = half.y().
struct Shape {
  enum class Kind { kSphere, kBox, kCylinder };
  Kind kind = Kind::kSphere;
  Vec3 center = Vec3::Zero();
  Vec3 half = Vec3::Constant(0.1);
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();

  static Shape Sphere(const Vec3& c, double r);
  static Shape Box(const Vec3& c, const Vec3& half, const Eigen::Matrix3d& rot = Eigen::Matrix3d::Identity());
  static Shape Cylinder(const Vec3& c, double r, double half_height,
                        const Eigen::Matrix3d& rot = Eigen::Matrix3d::Identity());

  // Exact signed distance (negative inside), metres.
  double Sdf(const Vec3& p) const;
  // Smallest t > 0 with o + t·d on the surface, or +inf.
  double Intersect(const Vec3& o, const Vec3& d) const;
};

// A union of shapes.
struct Scene {
  std::vector<Shape> shapes;
  double Sdf(const Vec3& p) const;
  double Intersect(const Vec3& o, const Vec3& d) const;
};

struct TurntableOptions {
  int frames = 60;         // evenly over 360°
  double distance = 1.2;   // camera to the y axis, metres
  double camera_y = 0.0;   // camera height in the object frame (gripper height)
  double target_y = -0.4;  // the camera looks at (0, target_y, 0)
  double noise_sigma = 0;  // Gaussian depth noise, metres
  double max_range = 4.0;  // beyond: no data
  // Depth of a backdrop where a ray misses the scene (like the sweep scene's wall and
  // floor); 0 = no data there.
  double background_depth = 3.0;
  uint64_t seed = 0;
};

// The camera circles the y axis (the garment turning on the gripper, seen in the
// object frame); frame i at angle 2πi/frames. Depth = z-depth of the first hit.
std::vector<DepthFrame> RenderTurntable(const Scene& scene, const Intrinsics& K, const TurntableOptions& options);

// Appends m's vertices and faces (renumbered) to `to`: one mesh of several shapes.
void AppendMesh(TriMesh& to, const TriMesh& m);

// A smaller camera than the Kinect that keeps tests fast: 320×240, the focal length
// halved with the resolution (a pixel spans ~4.6 mm at 1.2 m, ≈ 1.8 voxels at 384/m).
Intrinsics SmallCamera();

// Triangle meshes of shapes (outward counter-clockwise faces). Sphere: icosphere
// with `subdivisions` levels; box: 12 triangles; cylinder: `subdivisions`·16 sides.
TriMesh MeshShape(const Shape& shape, int subdivisions = 5);

}  // namespace drape::synthetic
