#include "runtime/folding/target.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/error.h"

namespace drape::folding {

IdealFold::IdealFold(const FoldLine& line, const Vec2& grasp, const Points3& current, double thickness, double reach) {
  if (!(line.direction.norm() > 1e-9) || !line.direction.allFinite() || !line.point.allFinite())
    throw Error("fold line: the two points coincide (or are not finite)");
  if (!(thickness >= 0)) throw Error("fold: thickness must be >= 0");
  line_ = line;
  line_.direction.normalize();
  normal_ = Vec2(-line_.direction.y(), line_.direction.x());
  const double s = normal_.dot(grasp - line_.point);
  if (std::abs(s) < 1e-6) throw Error("fold: a grasp point lies on the fold line");
  if (s < 0) normal_ = -normal_;
  if (!(reach > 0)) throw Error("fold: reach must be > 0");
  thickness_ = thickness;
  reach_ = reach;
  axis_height_ = StackTop(current, reach) + thickness / 2;
}

double IdealFold::StackTop(const Points3& current, double reach) const {
  if (!current.rows()) return 0;
  std::vector<Vec2> images;
  double top = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < current.rows(); ++i) {
    const Vec3 p = current.row(i).transpose();
    if (!Folds(p)) continue;
    top = std::max(top, p.y());
    const Vec3 image = Apply(p);  // its x, z (the height needs axis_height_)
    images.push_back(Vec2(image.x(), image.z()));
  }
  if (images.empty()) return current.col(1).maxCoeff();
  for (int i = 0; i < current.rows(); ++i) {
    const Vec3 p = current.row(i).transpose();
    if (Folds(p) || !(p.y() > top)) continue;
    for (const Vec2& q : images)
      if ((Vec2(p.x(), p.z()) - q).norm() <= reach) {
        top = p.y();
        break;
      }
  }
  return top;
}

double IdealFold::Side(const Vec3& p) const { return normal_.dot(Vec2(p.x(), p.z()) - line_.point); }

bool IdealFold::Folds(const Vec3& p) const { return Side(p) > 0; }

Vec3 IdealFold::Apply(const Vec3& p) const {
  const double s = Side(p);
  if (!(s > 0)) return p;
  const Vec2 q = Vec2(p.x(), p.z()) - 2 * s * normal_;
  return Vec3(q.x(), 2 * axis_height_ - p.y(), q.y());
}

Eigen::Matrix3d IdealFold::Rotation(double fraction) const {
  const Vec3 axis = Axis();
  // A quarter turn must carry the folded side's normal upwards.
  const Vec3 n(normal_.x(), 0, normal_.y());
  const double sign = axis.cross(n).y() > 0 ? 1 : -1;
  return Eigen::AngleAxisd(sign * M_PI * fraction, axis).toRotationMatrix();
}

TriMesh TargetShape(const TriMesh& current, const IdealFold& fold) {
  TriMesh t = current;
  for (int i = 0; i < t.NumVertices(); ++i) t.V.row(i) = fold.Apply(current.V.row(i).transpose()).transpose();
  return t;
}

TriMesh LandedFold(const TriMesh& stack, const IdealFold& fold) {
  const Points3& V = stack.V;
  TriMesh t = stack;
  if (!V.rows()) return t;
  const double thickness = fold.thickness(), reach = fold.reach();
  const double table = V.col(1).minCoeff() - thickness;
  auto xz = [](const Vec3& p) { return Vec2(p.x(), p.z()); };
  std::vector<char> folds(V.rows());
  for (int j = 0; j < V.rows(); ++j) folds[j] = fold.Folds(V.row(j).transpose());
  for (int i = 0; i < V.rows(); ++i) {
    if (!folds[i]) continue;
    const Vec3 p = V.row(i).transpose();
    const Vec3 image = fold.Apply(p);
    double folded_top = p.y(), under_top = table;
    for (int j = 0; j < V.rows(); ++j) {
      const Vec3 u = V.row(j).transpose();
      if (folds[j]) {
        if ((xz(u) - xz(p)).norm() <= reach) folded_top = std::max(folded_top, u.y());
      } else if ((xz(u) - xz(image)).norm() <= reach) {
        under_top = std::max(under_top, u.y());
      }
    }
    t.V.row(i) = Vec3(image.x(), under_top + thickness + folded_top - p.y(), image.z()).transpose();
  }
  return t;
}

double LongestEdge(const TriMesh& mesh) {
  double longest = 0;
  for (const auto& e : UniqueEdges(mesh)) longest = std::max(longest, (mesh.V.row(e[0]) - mesh.V.row(e[1])).norm());
  return longest;
}

}  // namespace drape::folding
