#include "common/closest_point.h"

#include <algorithm>
#include <limits>

#include "common/embree.h"
#include "common/error.h"

namespace drape {

ClosestPoint ClosestOnTriangle(const TriMesh& mesh, int f, const Vec3& p) {
  const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
  ClosestPoint r;
  r.point = ClosestPointOnTriangle(p, a, b, c);
  r.distance = (p - r.point).norm();
  r.triangle = f;
  return r;
}

ClosestPoint BruteForceClosestPoint(const TriMesh& mesh, const Vec3& p) {
  ClosestPoint best;
  best.distance = std::numeric_limits<double>::infinity();
  for (int f = 0; f < mesh.NumFaces(); ++f) {
    ClosestPoint c = ClosestOnTriangle(mesh, f, p);
    if (c.distance < best.distance) best = c;
  }
  return best;
}

struct ExactClosestPoint::Impl {
  TriMesh mesh;
  double max_abs_coordinate = 0;  // metres: the float rounding of the BVH scales with it
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

namespace {

struct QueryState {
  const TriMesh* mesh;
  Vec3 p;
  double pad;  // metres added to the search radius (see Query)
  ClosestPoint best;
};

bool PointQueryCallback(RTCPointQueryFunctionArguments* args) {
  auto* s = static_cast<QueryState*>(args->userPtr);
  const int f = static_cast<int>(args->primID);
  ClosestPoint c = ClosestOnTriangle(*s->mesh, f, s->p);
  // Ties go to the lower index so the answer does not depend on traversal order.
  if (c.distance < s->best.distance || (c.distance == s->best.distance && f < s->best.triangle)) {
    s->best = c;
    // Shrink the search radius, padded: the BVH bounds and the query centre are floats.
    args->query->radius = static_cast<float>(c.distance * (1 + 1e-6) + s->pad);
    return true;
  }
  return false;
}

}  // namespace

ExactClosestPoint::ExactClosestPoint(const TriMesh& mesh) : impl_(std::make_unique<Impl>()) {
  if (mesh.NumFaces() == 0) throw Error("closest-point query: target mesh has no faces");
  impl_->mesh = mesh;
  if (mesh.NumVertices()) impl_->max_abs_coordinate = mesh.V.cwiseAbs().maxCoeff();
  // The answers are exact (double) whatever the BVH, so any ISA will do when the
  // pinned one is missing.
  try {
    impl_->device = NewEmbreeDevice();
  } catch (const Error&) {
    impl_->device = NewEmbreeDevice("");
  }
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry geom = NewTriangleGeometry(impl_->device, mesh);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  rtcCommitScene(impl_->scene);
}

ExactClosestPoint::~ExactClosestPoint() {
  if (impl_) {
    if (impl_->scene) rtcReleaseScene(impl_->scene);
    if (impl_->device) rtcReleaseDevice(impl_->device);
  }
}

const TriMesh& ExactClosestPoint::mesh() const { return impl_->mesh; }

ClosestPoint ExactClosestPoint::Query(const Vec3& p) const {
  // Float rounding moves the query centre and every BVH bound by at most
  // 2^-24 |coordinate| per axis; 1e-6 of the largest coordinate is ~8 times that, so
  // the closest triangle is never culled however close the query is to the mesh.
  const double pad = 1e-6 * std::max(impl_->max_abs_coordinate, p.cwiseAbs().maxCoeff()) + 1e-9;
  QueryState s{&impl_->mesh, p, pad, {}};
  s.best.distance = std::numeric_limits<double>::infinity();
  RTCPointQuery q;
  q.x = static_cast<float>(p.x());
  q.y = static_cast<float>(p.y());
  q.z = static_cast<float>(p.z());
  q.time = 0;
  q.radius = std::numeric_limits<float>::infinity();
  RTCPointQueryContext ctx;
  rtcInitPointQueryContext(&ctx);
  rtcPointQuery(impl_->scene, &q, &ctx, PointQueryCallback, &s);
  DRAPE_CHECK(s.best.triangle >= 0, "point query found no triangle");
  return s.best;
}

}  // namespace drape
