#include "runtime/registration/closest_point.h"

#include <embree3/rtcore.h>

#include <limits>

#include "common/error.h"

namespace drape::registration {

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
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

namespace {

struct QueryState {
  const TriMesh* mesh;
  Vec3 p;
  ClosestPoint best;
};

bool PointQueryCallback(RTCPointQueryFunctionArguments* args) {
  auto* s = static_cast<QueryState*>(args->userPtr);
  const int f = static_cast<int>(args->primID);
  ClosestPoint c = ClosestOnTriangle(*s->mesh, f, s->p);
  // Ties go to the lower index so the answer does not depend on traversal order.
  if (c.distance < s->best.distance ||
      (c.distance == s->best.distance && f < s->best.triangle)) {
    s->best = c;
    // Shrink the search radius (slightly padded: the BVH bounds are floats).
    args->query->radius = static_cast<float>(c.distance * (1 + 1e-6) + 1e-9);
    return true;
  }
  return false;
}

}  // namespace

ExactClosestPoint::ExactClosestPoint(const TriMesh& mesh) : impl_(std::make_unique<Impl>()) {
  if (mesh.NumFaces() == 0) throw Error("closest-point query: target mesh has no faces");
  impl_->mesh = mesh;
  // Pinned ISA as in the rest of drape; the answers are computed in double anyway.
  impl_->device = rtcNewDevice("isa=avx2");
  if (!impl_->device) impl_->device = rtcNewDevice(nullptr);
  DRAPE_CHECK(impl_->device != nullptr, "rtcNewDevice failed");
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                         RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                         mesh.NumVertices()));
  for (int v = 0; v < mesh.NumVertices(); ++v)
    for (int k = 0; k < 3; ++k) vb[3 * v + k] = static_cast<float>(mesh.V(v, k));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                                            RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                                            mesh.NumFaces()));
  for (int f = 0; f < mesh.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) ib[3 * f + k] = static_cast<unsigned>(mesh.F(f, k));
  rtcCommitGeometry(geom);
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
  QueryState s{&impl_->mesh, p, {}};
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

}  // namespace drape::registration
