// Depth cameras and frames, shared by the synthetic Kinect (sweep), fusion and the
// runtime's recorded-sweep queries.
// Camera frame: x right, y down, z forward (OpenCV/Open3D). World frame: y up.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace drape {

// Pinhole intrinsics in pixels. Default: the common PrimeSense/Kinect v1 values.
struct Intrinsics {
  int width = 640;
  int height = 480;
  double fx = 525.0;
  double fy = 525.0;
  double cx = 319.5;
  double cy = 239.5;
};

// One depth image. depth is row-major height×width, metres along the optical axis
// (z-depth), 0 = no data. camera_to_object maps camera coordinates into the frame
// of the object being scanned (the garment, which turns with the gripper), so a
// sweep of a turning garment fuses like a static scene.
struct DepthFrame {
  std::vector<float> depth;
  Eigen::Isometry3d camera_to_object = Eigen::Isometry3d::Identity();
  // Camera in the fixed world frame (robot base), for reference and previews.
  Eigen::Isometry3d camera_to_world = Eigen::Isometry3d::Identity();
  // Rotation of the gripper about the vertical axis at this frame (radians).
  double gripper_angle = 0.0;
};

}  // namespace drape
