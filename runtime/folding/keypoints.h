// Key points of a flat garment from the binary mask a camera above the table sees
// (paper §"Trajectory Optimization for Folding": "a fast and robust algorithm that can
// detect garment key points such as sleeve ends, collar, and waist corner"): the
// largest outer contour (OpenCV findContours), its convex hull and convexity defects
// (armpits, crotch, collar), and extreme points along the axes and diagonals (corners,
// cuffs, hem and waist corners). Names follow garments/anchors.md.
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/mesh.h"

namespace drape::folding {

// The names DetectKeyPoints returns for a category (empty for an unknown one).
// Categories: towel, pants, shorts, long_sleeve_shirt, tshirt.
const std::vector<std::string>& KeyPointNames(const std::string& category);

struct KeyPointOptions {
  // The outline is simplified to its corners (cv::approxPolyDP) with this tolerance,
  // relative to the garment's width; sleeve ends are the middle of a corner-to-corner edge.
  double corner_tolerance = 0.01;
  // Convexity defects shallower than this fraction of the garment's width are ignored.
  double min_defect_depth = 0.02;
  // The neck notch may be shallower: a shirt laid front up shows the back neckline in its
  // outline (~2 cm deep, 1.3 % of a shirt's width), the front's lower one lies inside it.
  // So the detected `collar` is the bottom of the back neckline, not the front's anchor.
  double min_neck_depth = 0.005;
  void Validate() const;
};

// Key points in the mask's frame: x = column + 0.5 (right), y = −(row + 0.5) (up),
// pixels. The mask is CV_8UC1, non-zero = garment, with the garment upright (collar or
// waist towards row 0). Throws drape::Error if the mask is empty or a feature the
// category needs is missing (e.g. no defect between the legs), naming it.
std::map<std::string, Vec2> DetectKeyPoints(const cv::Mat& mask, const std::string& category,
                                            const KeyPointOptions& options = {});

}  // namespace drape::folding
