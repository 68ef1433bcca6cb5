#include "generator/fusion/synthetic.h"

#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "common/error.h"
#include "common/rng.h"

namespace drape::synthetic {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

Shape Shape::Sphere(const Vec3& c, double r) {
  Shape s;
  s.kind = Kind::kSphere;
  s.center = c;
  s.half = Vec3(r, r, r);
  return s;
}
Shape Shape::Box(const Vec3& c, const Vec3& half, const Eigen::Matrix3d& rot) {
  Shape s;
  s.kind = Kind::kBox;
  s.center = c;
  s.half = half;
  s.rotation = rot;
  return s;
}
Shape Shape::Cylinder(const Vec3& c, double r, double half_height, const Eigen::Matrix3d& rot) {
  Shape s;
  s.kind = Kind::kCylinder;
  s.center = c;
  s.half = Vec3(r, half_height, r);
  s.rotation = rot;
  return s;
}

double Shape::Sdf(const Vec3& p) const {
  const Vec3 q = rotation.transpose() * (p - center);
  switch (kind) {
    case Kind::kSphere:
      return q.norm() - half.x();
    case Kind::kBox: {
      const Vec3 d = q.cwiseAbs() - half;
      return d.cwiseMax(0.0).norm() + std::min(d.maxCoeff(), 0.0);
    }
    case Kind::kCylinder: {
      const Vec2 d(std::hypot(q.x(), q.z()) - half.x(), std::abs(q.y()) - half.y());
      return std::min(std::max(d.x(), d.y()), 0.0) + d.cwiseMax(0.0).norm();
    }
  }
  return kInf;
}

double Shape::Intersect(const Vec3& o_world, const Vec3& d_world) const {
  const Vec3 o = rotation.transpose() * (o_world - center);
  const Vec3 d = rotation.transpose() * d_world;
  double t0 = -kInf, t1 = kInf;
  auto slab = [&](double oa, double da, double h) {
    if (da == 0) {
      if (std::abs(oa) > h) t0 = kInf;
      return;
    }
    double a = (-h - oa) / da, b = (h - oa) / da;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  };
  switch (kind) {
    case Kind::kSphere: {
      const double a = d.squaredNorm(), b = o.dot(d), c = o.squaredNorm() - half.x() * half.x();
      const double disc = b * b - a * c;
      if (disc < 0) return kInf;
      const double s = std::sqrt(disc);
      t0 = (-b - s) / a;
      t1 = (-b + s) / a;
      break;
    }
    case Kind::kBox:
      for (int k = 0; k < 3; ++k) slab(o[k], d[k], half[k]);
      break;
    case Kind::kCylinder: {
      const double a = d.x() * d.x() + d.z() * d.z();
      const double b = o.x() * d.x() + o.z() * d.z();
      const double c = o.x() * o.x() + o.z() * o.z() - half.x() * half.x();
      if (a == 0) {
        if (c > 0) return kInf;
      } else {
        const double disc = b * b - a * c;
        if (disc < 0) return kInf;
        const double s = std::sqrt(disc);
        t0 = (-b - s) / a;
        t1 = (-b + s) / a;
      }
      slab(o.y(), d.y(), half.y());
      break;
    }
  }
  if (t0 > t1) return kInf;
  if (t0 > 0) return t0;
  return kInf;  // origin inside or behind: cameras are outside every shape
}

double Scene::Sdf(const Vec3& p) const {
  double d = kInf;
  for (const auto& s : shapes) d = std::min(d, s.Sdf(p));
  return d;
}

double Scene::Intersect(const Vec3& o, const Vec3& d) const {
  double t = kInf;
  for (const auto& s : shapes) t = std::min(t, s.Intersect(o, d));
  return t;
}

std::vector<DepthFrame> RenderTurntable(const Scene& scene, const Intrinsics& K, const TurntableOptions& opt) {
  if (opt.frames < 1) throw Error("TurntableOptions.frames: must be >= 1");
  std::vector<DepthFrame> frames(opt.frames);
  for (int i = 0; i < opt.frames; ++i) {
    const double phi = 2 * M_PI * i / opt.frames;
    const Vec3 eye(opt.distance * std::sin(phi), opt.camera_y, opt.distance * std::cos(phi));
    const Vec3 target(0, opt.target_y, 0);
    const Vec3 z = (target - eye).normalized();
    const Vec3 x = z.cross(Vec3::UnitY()).normalized();
    const Vec3 y = z.cross(x);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear().col(0) = x;
    pose.linear().col(1) = y;
    pose.linear().col(2) = z;
    pose.translation() = eye;
    DepthFrame& f = frames[i];
    f.camera_to_object = pose;
    f.camera_to_world = pose;
    f.gripper_angle = -phi;
    f.depth.assign(size_t(K.width) * K.height, 0.f);
    Rng rng(DeriveSeed(opt.seed, "synthetic/frame/" + std::to_string(i)));
    for (int v = 0; v < K.height; ++v) {
      for (int u = 0; u < K.width; ++u) {
        // Unnormalised direction with camera z = 1: t is the z-depth.
        const Vec3 dir = pose.linear() * Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1);
        double t = scene.Intersect(eye, dir);
        if (!std::isfinite(t) && opt.background_depth > 0) t = opt.background_depth;
        if (!(t < opt.max_range)) continue;
        if (opt.noise_sigma > 0) t += rng.Normal(0, opt.noise_sigma);
        f.depth[size_t(v) * K.width + u] = float(t);
      }
    }
  }
  return frames;
}

void AppendMesh(TriMesh& to, const TriMesh& m) {
  const int nv = to.NumVertices(), nf = to.NumFaces();
  to.V.conservativeResize(nv + m.NumVertices(), 3);
  to.F.conservativeResize(nf + m.NumFaces(), 3);
  to.V.bottomRows(m.NumVertices()) = m.V;
  to.F.bottomRows(m.NumFaces()) = m.F.array() + nv;
}

Intrinsics SmallCamera() {
  Intrinsics K;
  K.width = 320;
  K.height = 240;
  K.fx = K.fy = 262.5;
  K.cx = 159.5;
  K.cy = 119.5;
  return K;
}

TriMesh MeshShape(const Shape& shape, int subdivisions) {
  TriMesh m;
  std::vector<Vec3> V;
  std::vector<std::array<int, 3>> F;
  switch (shape.kind) {
    case Shape::Kind::kSphere: {
      const double t = (1 + std::sqrt(5.0)) / 2;
      V = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
           {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
      for (auto& v : V) v.normalize();
      F = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
           {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
           {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
      for (int s = 0; s < subdivisions; ++s) {
        std::map<std::pair<int, int>, int> mid;
        auto midpoint = [&](int a, int b) {
          auto key = std::minmax(a, b);
          auto it = mid.find(key);
          if (it != mid.end()) return it->second;
          V.push_back((V[a] + V[b]).normalized());
          mid[key] = int(V.size()) - 1;
          return int(V.size()) - 1;
        };
        std::vector<std::array<int, 3>> G;
        for (const auto& f : F) {
          const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
          G.push_back({f[0], a, c});
          G.push_back({f[1], b, a});
          G.push_back({f[2], c, b});
          G.push_back({a, b, c});
        }
        F.swap(G);
      }
      for (auto& v : V) v = shape.center + shape.half.x() * v;
      break;
    }
    case Shape::Kind::kBox: {
      for (int i = 0; i < 8; ++i) V.push_back(Vec3(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
      F = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
           {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
      for (auto& v : V) v = shape.center + shape.rotation * v.cwiseProduct(shape.half);
      break;
    }
    case Shape::Kind::kCylinder: {
      const int n = std::max(8, 16 * std::max(1, subdivisions));
      const double r = shape.half.x(), hh = shape.half.y();
      for (int i = 0; i < n; ++i) {
        const double a = 2 * M_PI * i / n;
        V.push_back(Vec3(r * std::cos(a), -hh, r * std::sin(a)));
        V.push_back(Vec3(r * std::cos(a), hh, r * std::sin(a)));
      }
      const int bottom = int(V.size()), top = bottom + 1;
      V.push_back(Vec3(0, -hh, 0));
      V.push_back(Vec3(0, hh, 0));
      for (int i = 0; i < n; ++i) {
        const int j = (i + 1) % n;
        F.push_back({2 * i, 2 * i + 1, 2 * j});
        F.push_back({2 * j, 2 * i + 1, 2 * j + 1});
        F.push_back({bottom, 2 * i, 2 * j});
        F.push_back({top, 2 * j + 1, 2 * i + 1});
      }
      for (auto& v : V) v = shape.center + shape.rotation * v;
      break;
    }
  }
  m.V.resize(V.size(), 3);
  for (size_t i = 0; i < V.size(); ++i) m.V.row(i) = V[i];
  m.F.resize(F.size(), 3);
  for (size_t i = 0; i < F.size(); ++i) m.F.row(i) << F[i][0], F[i][1], F[i][2];
  return m;
}

}  // namespace drape::synthetic
