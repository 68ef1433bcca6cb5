// The flat garment on the table and the camera above it. World frame y up (table top
// at y = TableOptions::top); a flat garment's pattern (x right, y towards the collar,
// front layer at +z) is laid front up: world = (x, top + clearance + gap/2 + z, −y),
// so the top-down picture (x right, y towards the collar) is world (x, −z).
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <string>

#include "common/mesh.h"

namespace drape::tabletop {

struct TableOptions {
  double top = 0.0;                   // m, height of the table top (world y)
  double half_x = 1.0, half_z = 1.0;  // m, half sizes of the top
  double thickness = 0.05;            // m
  double clearance = 0.002;           // m, gap between the table and the back layer when laid
  void Validate() const;
};

// Lays a flat garment mesh (pattern frame) front up on the table, its pattern
// bounding-box centre moved to `offset` (world x, z) and turned by `yaw` (radians,
// about world y). Faces keep their order and winding.
Points3 LayFlat(const TriMesh& flat, const TableOptions& table, const Vec2& offset = Vec2::Zero(), double yaw = 0);

// A garment lying on some table (world y up; e.g. as `drape unfold` placed it) moved
// onto this one as LayFlat would lay its pattern: turned about the vertical so that the
// pattern's up (collar/waist) points to world −z as the camera expects — the yaw of the
// 2-D least-squares rotation of the pattern's x–y onto the lying x–z, what the placing
// robot knows from the points it held — its x–z bounding-box centre at `offset`, turned
// further by `yaw` (LayFlat's sense), its lowest point `clearance` above the top. Its
// shape is kept. Throws drape::Error if `pattern` has other vertices.
Points3 PlaceOnTable(const Points3& lying, const TriMesh& pattern, const TableOptions& table,
                     const Vec2& offset = Vec2::Zero(), double yaw = 0);

// An orthographic camera straight above the table looking down, picture x = world x,
// picture up = world −z; `metres_per_pixel`, centred on (cx, cz).
struct TopDownCamera {
  int width = 400, height = 400;
  double metres_per_pixel = 0.004;
  double cx = 0, cz = 0;  // world x, z at the picture's centre
  // Picture frame of keypoints.h (x = column + ½, y = −(row + ½), pixels) ↔ world.
  Vec2 ToWorldXZ(const Vec2& frame) const;
  Vec2 ToFrame(double x, double z) const;
};

// A camera framing `positions` (world) with `margin` metres around them.
TopDownCamera FrameCamera(const Points3& positions, double metres_per_pixel, double margin = 0.05);

// The garment's binary mask as the camera sees it (CV_8UC1, 255 = cloth).
cv::Mat TopDownMask(const TriMesh& world_mesh, const TopDownCamera& camera);
// A shaded picture (CV_8UC3, white background) of the cloth seen from above.
cv::Mat TopDownPicture(const TriMesh& world_mesh, const TopDownCamera& camera, const cv::Scalar& colour);

}  // namespace drape::tabletop
