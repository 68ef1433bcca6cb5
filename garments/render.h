// Orthographic flat-shaded mesh drawing with OpenCV, shared by the build's entry
// previews and the runtime's registration figures: object frame seen from +z, faces
// painted far to near (ties by index, so pixels are deterministic), shade = |n·l|.
#pragma once

#include <opencv2/core.hpp>

#include "common/mesh.h"

namespace drape {

// Maps object-frame x (right) and y (up) to pixels: the point (cx, cy) lands at
// (width/2, height/2 + y_offset); `scale` is pixels per metre.
struct OrthoView {
  int width = 0, height = 0;
  double scale = 1, cx = 0, cy = 0, y_offset = 0;
  cv::Point2d Project(const Vec3& p) const {
    return {width / 2.0 + (p.x() - cx) * scale, height / 2.0 + y_offset - (p.y() - cy) * scale};
  }
};

// Fills the mesh's faces into img (CV_8UC3) in `base` colour times the shade.
void DrawShadedMesh(cv::Mat& img, const TriMesh& mesh, const OrthoView& view, const cv::Scalar& base);

}  // namespace drape
