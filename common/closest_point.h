// Exact closest-point queries on a triangle mesh: an Embree BVH (rtcPointQuery) and a
// brute-force reference. Used by fusion's accuracy (recon ↔ truth distances), the
// registration error metric, and as the reference the registration's closest-point
// grid is tested and benchmarked against. Library drape_embree.
#pragma once

#include <memory>

#include "common/mesh.h"

namespace drape {

// One closest-point answer: the point on the mesh (metres), its distance to the query
// (metres) and the triangle it lies on (-1 only for an empty mesh).
struct ClosestPoint {
  Vec3 point = Vec3::Zero();
  double distance = 0;
  int triangle = -1;
};

// Closest point on triangle `f` of `mesh` to p (distance computed in double).
ClosestPoint ClosestOnTriangle(const TriMesh& mesh, int f, const Vec3& p);

// O(#F) scan: the reference. Ties go to the lowest triangle index.
ClosestPoint BruteForceClosestPoint(const TriMesh& mesh, const Vec3& p);

// Exact closest points via Embree's BVH point query. The mesh is copied (float BVH
// bounds, double distance computations), so the object is self-contained. Queries are
// const and thread-safe. Throws drape::Error for a mesh without faces.
class ExactClosestPoint {
 public:
  explicit ExactClosestPoint(const TriMesh& mesh);
  ~ExactClosestPoint();
  ExactClosestPoint(const ExactClosestPoint&) = delete;
  ExactClosestPoint& operator=(const ExactClosestPoint&) = delete;

  ClosestPoint Query(const Vec3& p) const;
  const TriMesh& mesh() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace drape
