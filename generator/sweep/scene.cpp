// SweepScene: Embree scenes of the garment (object frame) and the world-fixed
// background, and the packet ray casting of one frame.
//
// Why two scenes: the background is fixed in the world and so is the camera, so its
// depth image is the same in every frame and is cast once. Only the garment and the
// gripper turn; their rays are cast in the object frame (the camera turns around a
// static garment: no scene rebuild per frame, frames can be cast in parallel) and only
// for the pixels whose rays can reach the turned bounds of the garment.
//
// Why every triangle test is ours: Embree's triangle intersectors divide by an
// approximate reciprocal (rcpps and one Newton step) and decide edges by formulas that
// differ between ISAs, so the last bits of a depth, and now and then whether a ray
// grazing an edge hits, differed between CPU makers and ISAs, and one bit of one depth
// moves a release's digest. The triangles are Embree user geometries: Embree's tree
// (robust mode: conservative box tests) proposes them, IntersectTriangle decides in
// double, and each ray keeps its nearest hit (ExactContext) by a rule that does not
// depend on the order in which the tree is walked.
#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <tuple>

#include "common/embree.h"
#include "common/error.h"
#include "generator/sweep/sweep.h"

namespace drape {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct MeshBuffers {
  std::vector<float> v;     // x, y, z per vertex
  std::vector<unsigned> f;  // 3 per triangle
  void AddTriangle(unsigned a, unsigned b, unsigned c) {
    f.push_back(a);
    f.push_back(b);
    f.push_back(c);
  }
  unsigned AddVertex(double x, double y, double z) {
    v.push_back(float(x));
    v.push_back(float(y));
    v.push_back(float(z));
    return unsigned(v.size() / 3 - 1);
  }
  // Axis-aligned box [lo, hi], 12 triangles, outward normals.
  void AddBox(const Vec3& lo, const Vec3& hi) {
    unsigned b = unsigned(v.size() / 3);
    for (int i = 0; i < 8; ++i) AddVertex(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
    static const int q[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    for (const auto& s : q) {
      AddTriangle(b + s[0], b + s[1], b + s[2]);
      AddTriangle(b + s[0], b + s[2], b + s[3]);
    }
  }
  // Vertical closed cylinder about (cx, ·, cz), radius r, y in [y0, y1].
  void AddCylinder(double cx, double cz, double r, double y0, double y1, int segments) {
    unsigned b = unsigned(v.size() / 3);
    for (int i = 0; i < segments; ++i) {
      double a = 2 * M_PI * i / segments;
      AddVertex(cx + r * std::cos(a), y0, cz + r * std::sin(a));
      AddVertex(cx + r * std::cos(a), y1, cz + r * std::sin(a));
    }
    unsigned c0 = AddVertex(cx, y0, cz), c1 = AddVertex(cx, y1, cz);
    for (int i = 0; i < segments; ++i) {
      unsigned a0 = b + 2 * i, a1 = a0 + 1;
      unsigned n0 = b + 2 * ((i + 1) % segments), n1 = n0 + 1;
      AddTriangle(a0, a1, n1);
      AddTriangle(a0, n1, n0);
      AddTriangle(c0, a0, n0);
      AddTriangle(c1, n1, a1);
    }
  }
  bool empty() const { return f.empty(); }
};

Vec3 Vertex(const MeshBuffers& m, unsigned prim, int k) {
  const size_t i = m.f[3 * size_t(prim) + k];
  return Vec3(m.v[3 * i], m.v[3 * i + 1], m.v[3 * i + 2]);
}

// A ray o + t·d in the shear frame of Woop, Benthin & Wald's watertight test (JCGT
// 2013): kz the axis of d's largest component, (kx, ky) the others in the order that
// keeps the frame right-handed.
struct ShearedRay {
  Vec3 o;
  int kx = 0, ky = 1, kz = 2;
  double sx = 0, sy = 0, sz = 1;
  ShearedRay() = default;
  ShearedRay(const Vec3& origin, const Vec3& d) : o(origin) {
    const Vec3 ad = d.cwiseAbs();
    kz = ad.x() >= ad.y() ? (ad.x() >= ad.z() ? 0 : 2) : (ad.y() >= ad.z() ? 1 : 2);
    kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    if (d[kz] < 0) std::swap(kx, ky);
    sx = d[kx] / d[kz], sy = d[ky] / d[kz], sz = 1 / d[kz];
  }
};

// The watertight test in double: *t of the ray's hit with triangle `prim` of m, both
// faces. A vertex's coordinates in the shear frame do not depend on the triangle, so an
// edge shared by two triangles has the same edge function in both with the opposite
// sign: no ray passes between them.
bool IntersectTriangle(const MeshBuffers& m, unsigned prim, const ShearedRay& r, double* t) {
  const Vec3 a = Vertex(m, prim, 0) - r.o, b = Vertex(m, prim, 1) - r.o, c = Vertex(m, prim, 2) - r.o;
  const double ax = a[r.kx] - r.sx * a[r.kz], ay = a[r.ky] - r.sy * a[r.kz];
  const double bx = b[r.kx] - r.sx * b[r.kz], by = b[r.ky] - r.sy * b[r.kz];
  const double cx = c[r.kx] - r.sx * c[r.kz], cy = c[r.ky] - r.sy * c[r.kz];
  const double u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
  if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return false;
  const double det = u + v + w;
  if (det == 0) return false;
  *t = (u * (r.sz * a[r.kz]) + v * (r.sz * b[r.kz]) + w * (r.sz * c[r.kz])) / det;
  return std::isfinite(*t);
}

// Up to 16 rays by ray id, as Embree has them in float, and the nearest hit of each in
// double. An RTCIntersectContext first: Embree hands the callbacks a pointer to it.
struct ExactContext {
  RTCIntersectContext context;
  std::array<ShearedRay, 16> ray;
  std::array<double, 16> t;
  std::array<unsigned, 16> geom, prim;
  void Reset() {
    t.fill(std::numeric_limits<double>::infinity());
    geom.fill(RTC_INVALID_GEOMETRY_ID);
    prim.fill(0);
  }
};

void TriangleBounds(const RTCBoundsFunctionArguments* args) {
  const auto& m = *static_cast<const MeshBuffers*>(args->geometryUserPtr);
  RTCBounds& b = *args->bounds_o;
  b.lower_x = b.lower_y = b.lower_z = std::numeric_limits<float>::infinity();
  b.upper_x = b.upper_y = b.upper_z = -std::numeric_limits<float>::infinity();
  for (int k = 0; k < 3; ++k) {
    const float* p = &m.v[3 * size_t(m.f[3 * size_t(args->primID) + k])];
    b.lower_x = std::min(b.lower_x, p[0]), b.upper_x = std::max(b.upper_x, p[0]);
    b.lower_y = std::min(b.lower_y, p[1]), b.upper_y = std::max(b.upper_y, p[1]);
    b.lower_z = std::min(b.lower_z, p[2]), b.upper_z = std::max(b.upper_z, p[2]);
  }
}

// A triangle proposed by the tree: kept when it is nearer than the ray's hit so far, or
// as near with a lower (geometry, triangle): the same winner in any visiting order.
// tfar becomes the hit's distance rounded up to a float, so Embree skips only boxes
// beyond it.
void IntersectTriangles(const RTCIntersectFunctionNArguments* args) {
  const auto& m = *static_cast<const MeshBuffers*>(args->geometryUserPtr);
  auto& best = *reinterpret_cast<ExactContext*>(args->context);
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
  RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, args->N);
  const unsigned N = args->N;
  for (unsigned i = 0; i < N; ++i) {
    if (!args->valid[i]) continue;
    const unsigned id = RTCRayN_id(ray, N, i);
    double t = 0;
    if (!IntersectTriangle(m, args->primID, best.ray[id], &t) || !(t >= RTCRayN_tnear(ray, N, i))) continue;
    if (!(t < best.t[id] ||
          (t == best.t[id] && std::tie(args->geomID, args->primID) < std::tie(best.geom[id], best.prim[id]))))
      continue;
    best.t[id] = t;
    best.geom[id] = args->geomID;
    best.prim[id] = args->primID;
    float f = float(t);
    if (double(f) < t) f = std::nextafter(f, kInf);
    RTCRayN_tfar(ray, N, i) = f;
    RTCHitN_Ng_x(hit, N, i) = RTCHitN_Ng_y(hit, N, i) = RTCHitN_Ng_z(hit, N, i) = 0;
    RTCHitN_u(hit, N, i) = RTCHitN_v(hit, N, i) = 0;
    RTCHitN_primID(hit, N, i) = args->primID;
    RTCHitN_geomID(hit, N, i) = args->geomID;
    RTCHitN_instID(hit, N, i, 0) = args->context->instID[0];
  }
}

// Attaches m to scene as a user geometry of its triangles and keeps it in meshes at its
// geometry ID.
unsigned AttachMesh(RTCDevice device, RTCScene scene, MeshBuffers m,
                    std::vector<std::unique_ptr<const MeshBuffers>>& meshes) {
  auto owned = std::make_unique<const MeshBuffers>(std::move(m));
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(g, unsigned(owned->f.size() / 3));
  rtcSetGeometryUserData(g, const_cast<MeshBuffers*>(owned.get()));
  rtcSetGeometryBoundsFunction(g, TriangleBounds, nullptr);
  rtcSetGeometryIntersectFunction(g, IntersectTriangles);
  rtcCommitGeometry(g);
  const unsigned id = rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  if (meshes.size() <= id) meshes.resize(id + 1);
  meshes[id] = std::move(owned);
  return id;
}

// The cosine of incidence of a ray along d on triangle `prim` of m.
float CosIncidence(const MeshBuffers& m, unsigned prim, const Vec3& d) {
  const Vec3 p0 = Vertex(m, prim, 0);
  const Vec3 n = (Vertex(m, prim, 1) - p0).cross(Vertex(m, prim, 2) - p0);
  const double nn = std::sqrt(n.squaredNorm() * d.squaredNorm());
  return nn > 0 ? float(std::min(1.0, std::abs(n.dot(d)) / nn)) : 1.0f;
}

void ThrowOnDeviceError(RTCDevice device, const char* what) {
  RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE) {
    std::ostringstream os;
    os << "sweep: Embree error " << int(e) << " in " << what;
    throw NumericalError(os.str());
  }
}

// Gripper in the object frame: palm above the grasp point, two fingers pinching the
// cloth in the x–y plane (jaw gap 16 mm).
void AddGripper(MeshBuffers& m) {
  m.AddBox({-0.045, 0.03, -0.035}, {0.045, 0.11, 0.035});
  m.AddBox({-0.015, -0.015, 0.008}, {0.015, 0.03, 0.018});
  m.AddBox({-0.015, -0.015, -0.018}, {0.015, 0.03, -0.008});
}

// World-fixed background: arm, wall, floor, table.
void AddBackground(MeshBuffers& m, const SweepOptions& o) {
  const double g = o.gripper_height;
  m.AddCylinder(0, 0, 0.04, g + 0.11, g + 0.45, 24);             // wrist/forearm above the palm
  m.AddBox({-0.045, g + 0.37, -1.2}, {0.045, g + 0.46, -0.04});  // link to the robot behind
  const double wall_z = -1.2, half = 4.0;
  unsigned a = m.AddVertex(-half, 0, wall_z), b = m.AddVertex(half, 0, wall_z);
  unsigned c = m.AddVertex(half, 3.0, wall_z), d = m.AddVertex(-half, 3.0, wall_z);
  m.AddTriangle(a, b, c);
  m.AddTriangle(a, c, d);
  a = m.AddVertex(-half, 0, wall_z);
  b = m.AddVertex(-half, 0, o.camera_distance + 2.0);
  c = m.AddVertex(half, 0, o.camera_distance + 2.0);
  d = m.AddVertex(half, 0, wall_z);
  m.AddTriangle(a, b, c);
  m.AddTriangle(a, c, d);
  // Table to the camera's right, behind the garment: top 0.8 × 0.6 m at 0.72–0.75 m.
  m.AddBox({0.55, 0.72, -0.9}, {1.35, 0.75, -0.3});
  for (double x : {0.58, 1.28})
    for (double z : {-0.87, -0.37}) m.AddBox({x, 0.0, z}, {x + 0.04, 0.72, z + 0.04});
}

}  // namespace

void IrRangeOptions::Validate() const {
  if (!(min_range >= 0)) throw Error("ir.min_range: must be >= 0");
  if (!(max_range > min_range)) throw Error("ir.max_range: must be > min_range");
  if (!(sigma >= 0)) throw Error("ir.sigma: must be >= 0");
  if (!(sigma_per_metre >= 0)) throw Error("ir.sigma_per_metre: must be >= 0");
}

struct SweepScene::Impl {
  SweepOptions options;
  RTCDevice device = nullptr;
  RTCScene object = nullptr;      // garment (geomID 0) + gripper, object frame
  RTCScene background = nullptr;  // world frame; null if options.scene == false
  unsigned garment_geom = 0;
  // Each scene's triangles by geometry ID (the user geometries' data).
  std::vector<std::unique_ptr<const MeshBuffers>> object_meshes, background_meshes;
  Eigen::AlignedBox3d bounds;
  Eigen::Isometry3d camera_to_world;
  ExactFrame background_frame;  // cast once
  // Camera-frame ray slopes per column, (u − cx)/fx, and row, (v − cy)/fy (padded to 4).
  std::vector<float> ray_x, ray_y;
  std::shared_ptr<const KinectPlan> background_plan;  // if kinect.noise

  ~Impl() {
    if (object) rtcReleaseScene(object);
    if (background) rtcReleaseScene(background);
    if (device) rtcReleaseDevice(device);
  }

  // Casts the pixels of `rect` in `scene` from a camera at camera_to_scene, keeping the
  // nearest hit in frame. Returns the number of pixels whose nearest hit is geometry
  // `count_geom` of this scene.
  int Cast(RTCScene scene, const std::vector<std::unique_ptr<const MeshBuffers>>& meshes,
           const Eigen::Isometry3d& camera_to_scene, const PixelRect& rect, ExactFrame& frame,
           unsigned count_geom) const {
    const Intrinsics& K = options.kinect.intrinsics;
    const Eigen::Matrix3f R = camera_to_scene.linear().cast<float>();
    const Eigen::Vector3f o = camera_to_scene.translation().cast<float>();
    const Eigen::Vector3f r0 = R.col(0), r1 = R.col(1), r2 = R.col(2);
    const Vec3 origin = o.cast<double>();
    ExactContext best;
    rtcInitIntersectContext(&best.context);
    best.context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(64) RTCRayHit16 rh;
    alignas(64) int valid[16];
    // Rtc*Intersect16 only writes tfar and the hit: set the constant fields once.
    for (int k = 0; k < 16; ++k) {
      rh.ray.org_x[k] = o.x();
      rh.ray.org_y[k] = o.y();
      rh.ray.org_z[k] = o.z();
      rh.ray.tnear[k] = 0.0f;
      rh.ray.time[k] = 0.0f;
      rh.ray.mask[k] = 0xFFFFFFFFu;
      rh.ray.id[k] = unsigned(k);
      rh.ray.flags[k] = 0;
    }
    int counted = 0;
    for (int tv = rect.v0; tv < rect.v1; tv += 4) {
      for (int tu = rect.u0; tu < rect.u1; tu += 4) {
        for (int k = 0; k < 16; ++k) {
          const int u = tu + (k & 3), v = tv + (k >> 2);
          valid[k] = (u < K.width && v < K.height) ? -1 : 0;
          // Unnormalised direction with unit z in the camera: tfar is the z-depth
          // (rotation keeps the length).
          const Eigen::Vector3f d = ray_x[u] * r0 + ray_y[v] * r1 + r2;
          rh.ray.dir_x[k] = d.x();
          rh.ray.dir_y[k] = d.y();
          rh.ray.dir_z[k] = d.z();
          best.ray[k] = ShearedRay(origin, d.cast<double>());
          rh.ray.tfar[k] = kInf;
          rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        }
        best.Reset();
        rtcIntersect16(valid, scene, &best.context, &rh);
        for (int k = 0; k < 16; ++k) {
          if (!valid[k] || best.geom[k] == RTC_INVALID_GEOMETRY_ID) continue;
          const int u = tu + (k & 3), v = tv + (k >> 2);
          const size_t p = size_t(v) * K.width + u;
          const float z = float(best.t[k]);
          if (!(z < frame.depth[p])) continue;
          frame.depth[p] = z;
          const Vec3 d(rh.ray.dir_x[k], rh.ray.dir_y[k], rh.ray.dir_z[k]);
          frame.cos_incidence[p] = CosIncidence(*meshes[best.geom[k]], best.prim[k], d);
          if (best.geom[k] == count_geom) ++counted;
        }
        frame.rays_cast += 16;
      }
    }
    return counted;
  }
};

SweepScene::SweepScene(const TriMesh& hung, const SweepOptions& options) : impl_(std::make_unique<Impl>()) {
  options.Validate();
  if (hung.NumFaces() == 0 || hung.NumVertices() == 0) throw Error("sweep: the hung mesh is empty");
  if (!hung.V.allFinite()) throw Error("sweep: the hung mesh has non-finite vertices");
  if (hung.F.minCoeff() < 0 || hung.F.maxCoeff() >= hung.NumVertices())
    throw Error("sweep: the hung mesh has face indices out of range");
  Impl& m = *impl_;
  m.options = options;
  m.camera_to_world = CameraToWorld(options);

  m.device = NewEmbreeDevice(options.embree_isa, 1);

  MeshBuffers garment;
  garment.v.reserve(hung.V.size());
  for (int i = 0; i < hung.NumVertices(); ++i) garment.AddVertex(hung.V(i, 0), hung.V(i, 1), hung.V(i, 2));
  for (int i = 0; i < hung.NumFaces(); ++i)
    garment.AddTriangle(unsigned(hung.F(i, 0)), unsigned(hung.F(i, 1)), unsigned(hung.F(i, 2)));
  m.bounds = Bounds(hung);

  m.object = rtcNewScene(m.device);
  rtcSetSceneBuildQuality(m.object, RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneFlags(m.object, RTC_SCENE_FLAG_ROBUST);
  m.garment_geom = AttachMesh(m.device, m.object, std::move(garment), m.object_meshes);
  if (options.scene) {
    MeshBuffers gripper;
    AddGripper(gripper);
    for (size_t i = 0; i < gripper.v.size(); i += 3)
      m.bounds.extend(Vec3(gripper.v[i], gripper.v[i + 1], gripper.v[i + 2]));
    AttachMesh(m.device, m.object, std::move(gripper), m.object_meshes);
  }
  rtcCommitScene(m.object);
  ThrowOnDeviceError(m.device, "building the garment scene");

  const Intrinsics& K = options.kinect.intrinsics;
  const size_t n = size_t(K.width) * K.height;
  for (int u = 0; u < (K.width + 3) / 4 * 4; ++u) m.ray_x.push_back(float((u - K.cx) / K.fx));
  for (int v = 0; v < (K.height + 3) / 4 * 4; ++v) m.ray_y.push_back(float((v - K.cy) / K.fy));
  m.background_frame.depth.assign(n, kInf);
  m.background_frame.cos_incidence.assign(n, 1.0f);
  if (options.scene) {
    MeshBuffers bg;
    AddBackground(bg, options);
    m.background = rtcNewScene(m.device);
    rtcSetSceneFlags(m.background, RTC_SCENE_FLAG_ROBUST);
    AttachMesh(m.device, m.background, std::move(bg), m.background_meshes);
    rtcCommitScene(m.background);
    ThrowOnDeviceError(m.device, "building the background scene");
    PixelRect all{0, 0, (K.width + 3) / 4 * 4, (K.height + 3) / 4 * 4};
    m.Cast(m.background, m.background_meshes, m.camera_to_world, all, m.background_frame, RTC_INVALID_GEOMETRY_ID);
  }
  if (options.kinect.noise)
    m.background_plan = std::make_shared<const KinectPlan>(PlanKinectNoise(m.background_frame, options.kinect));
}

namespace {

// Copies rows [v0, v1), columns [u0, u1) of `from` into `to` (both width W).
template <typename T>
void CopyRect(const std::vector<T>& from, std::vector<T>& to, const PixelRect& r, int W) {
  for (int v = r.v0; v < r.v1; ++v)
    std::copy(from.begin() + size_t(v) * W + r.u0, from.begin() + size_t(v) * W + r.u1,
              to.begin() + size_t(v) * W + r.u0);
}

PixelRect Clip(PixelRect r, int W, int H) {
  r.u0 = std::clamp(r.u0, 0, W);
  r.u1 = std::clamp(r.u1, r.u0, W);
  r.v0 = std::clamp(r.v0, 0, H);
  r.v1 = std::clamp(r.v1, r.v0, H);
  return r;
}

}  // namespace

std::vector<float> SweepScene::RenderKinect(double angle, Rng& rng, KinectScratch* scratch) const {
  const Impl& m = *impl_;
  const KinectOptions& k = m.options.kinect;
  const int W = k.intrinsics.width, H = k.intrinsics.height;
  KinectScratch local;
  KinectScratch& s = scratch ? *scratch : local;
  // The scratch holds the background plus last frame's garment region: restore only that
  // region (whole-image copies would cost more than the noise).
  const PixelRect roi = Clip(Roi(angle), W, H);
  if (s.owner == this) {
    CopyRect(m.background_frame.depth, s.exact.depth, s.exact_dirty, W);
    CopyRect(m.background_frame.cos_incidence, s.exact.cos_incidence, s.exact_dirty, W);
  } else {
    s.exact.depth = m.background_frame.depth;
    s.exact.cos_incidence = m.background_frame.cos_incidence;
    if (m.background_plan) s.plan = *m.background_plan;
    s.owner = this;
    s.plan_dirty = s.exact_dirty = PixelRect{};
  }
  const Eigen::Isometry3d camera_to_object = ObjectToWorld(m.options, angle).inverse() * m.camera_to_world;
  s.exact.rays_cast = 0;
  s.exact.roi_pixels = Roi(angle).Area();
  s.exact.garment_pixels = m.Cast(m.object, m.object_meshes, camera_to_object, Roi(angle), s.exact, m.garment_geom);
  s.exact_dirty = roi;
  if (!k.noise) return DrawKinectNoise(s.exact, KinectPlan{}, k, rng, &s);
  // Only the garment's region changed: re-plan it, plus the widest projector shadow
  // (b·f/z px at the nearest range) to its left and one pixel around for depth edges.
  PixelRect r = roi;
  const int shadow = int(std::ceil(k.baseline * k.intrinsics.fx / k.min_range)) + 2;
  r.u0 -= shadow;
  r.u1 += 2;
  r.v0 -= 2;
  r.v1 += 2;
  r = Clip(r, W, H);
  const KinectPlan& bg = *m.background_plan;
  CopyRect(bg.sigma_axial, s.plan.sigma_axial, s.plan_dirty, W);
  CopyRect(bg.sigma_lateral, s.plan.sigma_lateral, s.plan_dirty, W);
  CopyRect(bg.p_drop, s.plan.p_drop, s.plan_dirty, W);
  CopyRect(bg.shadow_suffix, s.plan.shadow_suffix, s.plan_dirty, W);
  CopyRect(bg.lit, s.plan.lit, s.plan_dirty, W);
  UpdateKinectPlan(s.exact, k, r, s.plan);
  s.plan_dirty = r;
  return DrawKinectNoise(s.exact, s.plan, k, rng, &s);
}

SweepScene::~SweepScene() = default;

const SweepOptions& SweepScene::options() const { return impl_->options; }

Eigen::AlignedBox3d SweepScene::ObjectBounds() const { return impl_->bounds; }

PixelRect SweepScene::Roi(double angle) const {
  const Impl& m = *impl_;
  const Intrinsics& K = m.options.kinect.intrinsics;
  const PixelRect all{0, 0, (K.width + 3) / 4 * 4, (K.height + 3) / 4 * 4};
  const Eigen::Isometry3d object_to_camera = m.camera_to_world.inverse() * ObjectToWorld(m.options, angle);
  double umin = 1e30, umax = -1e30, vmin = 1e30, vmax = -1e30;
  // The projection of a box in front of the camera lies in the hull of its projected
  // corners.
  for (int c = 0; c < 8; ++c) {
    const Vec3 p = object_to_camera * m.bounds.corner(Eigen::AlignedBox3d::CornerType(c));
    if (p.z() < 1e-3) return all;
    const double u = K.fx * p.x() / p.z() + K.cx, v = K.fy * p.y() / p.z() + K.cy;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  }
  auto clampi = [](double x, int lo, int hi) { return int(std::clamp(x, double(lo), double(hi))); };
  PixelRect r;
  r.u0 = clampi(std::floor(umin) - 1, 0, K.width) / 4 * 4;
  r.v0 = clampi(std::floor(vmin) - 1, 0, K.height) / 4 * 4;
  r.u1 = (clampi(std::ceil(umax) + 2, 0, K.width) + 3) / 4 * 4;
  r.v1 = (clampi(std::ceil(vmax) + 2, 0, K.height) + 3) / 4 * 4;
  if (r.u1 <= r.u0 || r.v1 <= r.v0) r.u1 = r.u0, r.v1 = r.v0;
  return r;
}

ExactFrame SweepScene::RenderExact(double angle) const {
  ExactFrame frame;
  RenderExact(angle, frame);
  return frame;
}

void SweepScene::RenderExact(double angle, ExactFrame& frame) const {
  const Impl& m = *impl_;
  frame.depth = m.background_frame.depth;  // into the existing buffers
  frame.cos_incidence = m.background_frame.cos_incidence;
  frame.rays_cast = 0;
  const PixelRect roi = Roi(angle);
  frame.roi_pixels = roi.Area();
  const Eigen::Isometry3d camera_to_object = ObjectToWorld(m.options, angle).inverse() * m.camera_to_world;
  frame.garment_pixels = m.Cast(m.object, m.object_meshes, camera_to_object, roi, frame, m.garment_geom);
}

double SweepScene::RangeAlongRay(const Vec3& origin, const Vec3& dir, double angle, const IrRangeOptions& ir,
                                 Rng* rng) const {
  ir.Validate();
  const Impl& m = *impl_;
  const double len = dir.norm();
  if (!(len > 0) || !origin.allFinite() || !dir.allFinite())
    throw Error("sweep: RangeAlongRay needs a finite origin and a non-zero direction");
  const Vec3 d = dir / len;
  auto cast = [&](RTCScene scene, const Vec3& o, const Vec3& dd) {
    ExactContext best;
    rtcInitIntersectContext(&best.context);
    best.Reset();
    RTCRayHit rh;
    rh.ray.org_x = float(o.x());
    rh.ray.org_y = float(o.y());
    rh.ray.org_z = float(o.z());
    rh.ray.dir_x = float(dd.x());
    rh.ray.dir_y = float(dd.y());
    rh.ray.dir_z = float(dd.z());
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = kInf;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    best.ray[0] =
        ShearedRay(Vec3(rh.ray.org_x, rh.ray.org_y, rh.ray.org_z), Vec3(rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z));
    rtcIntersect1(scene, &best.context, &rh);
    return best.t[0];  // ∞ without a hit
  };
  const Eigen::Isometry3d world_to_object = ObjectToWorld(m.options, angle).inverse();
  double r = cast(m.object, world_to_object * origin, world_to_object.linear() * d);
  if (m.background) r = std::min(r, cast(m.background, origin, d));
  if (!(r >= ir.min_range && r <= ir.max_range)) return std::numeric_limits<double>::infinity();
  if (rng && ir.noise) r += (ir.sigma + ir.sigma_per_metre * r) * rng->Normal();
  return r;
}

}  // namespace drape
