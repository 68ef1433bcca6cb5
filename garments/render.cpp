#include "garments/render.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/imgproc.hpp>

namespace drape {

void DrawShadedMesh(cv::Mat& img, const TriMesh& mesh, const OrthoView& view, const cv::Scalar& base) {
  const Points3 n = FaceNormals(mesh);
  const Points3 c = FaceCentroids(mesh);
  std::vector<int> order(mesh.NumFaces());
  std::iota(order.begin(), order.end(), 0);
  // Far (small z) first; ties by index keep it deterministic.
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return c(a, 2) < c(b, 2); });
  const Vec3 light = Vec3(0.3, 0.5, 1.0).normalized();
  constexpr int kShift = 4;  // sub-pixel vertex positions
  for (int f : order) {
    const double shade = 0.25 + 0.75 * std::abs(n.row(f).dot(light));
    cv::Point pts[3];
    for (int k = 0; k < 3; ++k) {
      const cv::Point2d p = view.Project(mesh.V.row(mesh.F(f, k)).transpose());
      pts[k] = cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))),
                         static_cast<int>(std::lround(p.y * (1 << kShift))));
    }
    cv::fillConvexPoly(img, pts, 3, base * shade, cv::LINE_8, kShift);
  }
}

}  // namespace drape
