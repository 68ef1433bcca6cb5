#include "generator/sweep/sweep.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "common/error.h"
#include "common/files.h"
#include "common/json.h"

namespace drape {
namespace {

// A rectangle in the object-frame plane z = z0, x in [x0, x1], y in [y0, y1].
TriMesh Quad(double x0, double x1, double y0, double y1, double z0) {
  TriMesh m;
  m.V.resize(4, 3);
  m.V << x0, y0, z0, x1, y0, z0, x1, y1, z0, x0, y1, z0;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 2, 3;
  return m;
}

TriMesh UvSphere(const Vec3& c, double r, int slices, int stacks) {
  TriMesh m;
  m.V.resize(Eigen::Index{stacks + 1} * slices, 3);
  for (int i = 0; i <= stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      const double t = M_PI * i / stacks, p = 2 * M_PI * j / slices;
      m.V.row(i * slices + j) =
          (c + r * Vec3(std::sin(t) * std::cos(p), std::cos(t), std::sin(t) * std::sin(p))).transpose();
    }
  std::vector<std::array<int, 3>> f;
  for (int i = 0; i < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      const int a = i * slices + j, b = i * slices + (j + 1) % slices;
      f.push_back({a, a + slices, b + slices});
      f.push_back({a, b + slices, b});
    }
  m.F.resize(int(f.size()), 3);
  for (size_t k = 0; k < f.size(); ++k) m.F.row(int(k)) << f[k][0], f[k][1], f[k][2];
  return m;
}

TriMesh Box(const Vec3& lo, const Vec3& hi) {
  TriMesh m;
  m.V.resize(8, 3);
  for (int i = 0; i < 8; ++i)
    m.V.row(i) << (i & 1 ? hi.x() : lo.x()), (i & 2 ? hi.y() : lo.y()), (i & 4 ? hi.z() : lo.z());
  m.F.resize(12, 3);
  m.F << 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6;
  return m;
}

// A wavy hanging sheet, roughly garment-sized: 0.5 m wide, 0.9 m long, below the origin.
TriMesh WavySheet(int nx = 30, int ny = 50) {
  TriMesh m;
  m.V.resize(Eigen::Index{nx + 1} * (ny + 1), 3);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double x = -0.25 + 0.5 * i / nx, y = -0.02 - 0.9 * j / ny;
      m.V.row(j * (nx + 1) + i) << x, y, 0.06 * std::sin(9 * x) + 0.03 * std::cos(5 * y) + 0.1 * x * y;
    }
  m.F.resize(2 * Eigen::Index{nx} * ny, 3);
  int k = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i;
      m.F.row(k++) << a, a + nx + 1, a + 1;
      m.F.row(k++) << a + 1, a + nx + 1, a + nx + 2;
    }
  return m;
}

SweepOptions Flat(bool noise = false) {
  SweepOptions o;
  o.frames = 1;
  o.scene = false;
  o.look_at_height = o.camera_height;  // optical axis horizontal
  o.kinect.noise = noise;
  return o;
}

// Ray direction of pixel (u, v) in the camera frame, unit z.
Vec3 PixelRay(const Intrinsics& K, int u, int v) { return Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0); }

// Brute-force nearest hit (Möller–Trumbore, double), parameter along `d`.
double BruteHit(const TriMesh& m, const Vec3& o, const Vec3& d) {
  double best = std::numeric_limits<double>::infinity();
  for (int f = 0; f < m.NumFaces(); ++f) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const Vec3 e1 = b - a, e2 = c - a, p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-14) continue;
    const Vec3 s = o - a;
    const double u = s.dot(p) / det;
    if (u < 0 || u > 1) continue;
    const Vec3 q = s.cross(e1);
    const double v = d.dot(q) / det;
    if (v < 0 || u + v > 1) continue;
    const double t = e2.dot(q) / det;
    if (t > 0 && t < best) best = t;
  }
  return best;
}

double DistanceToMesh(const TriMesh& m, const Vec3& p) {
  double best = 1e30;
  for (int f = 0; f < m.NumFaces(); ++f)
    best = std::min(best,
                    (ClosestPointOnTriangle(p, m.V.row(m.F(f, 0)), m.V.row(m.F(f, 1)), m.V.row(m.F(f, 2))) - p).norm());
  return best;
}

double Std(const std::vector<double>& x, double* mean_out = nullptr) {
  double mean = 0;
  for (double v : x) mean += v;
  mean /= x.size();
  double var = 0;
  for (double v : x) var += (v - mean) * (v - mean);
  if (mean_out) *mean_out = mean;
  return std::sqrt(var / (x.size() - 1));
}

TEST(Sweep, PlaneDepthIsExact) {
  const SweepOptions o = Flat();
  for (double D : {0.8, 1.0, 2.0, 3.5}) {
    const Sweep s = SimulateSweep(Quad(-5, 5, -5, 5, o.camera_distance - D), o, 1);
    ASSERT_EQ(s.frames.size(), 1u);
    const auto& z = s.frames[0].depth;
    ASSERT_EQ(z.size(), 640u * 480u);
    for (size_t p = 0; p < z.size(); ++p) ASSERT_NEAR(z[p], D, 1e-4) << "pixel " << p << " D " << D;
  }
}

TEST(Sweep, SphereDepthMatchesAnalytic) {
  SweepOptions o;  // default tilted camera
  o.frames = 1;
  o.scene = false;
  o.kinect.noise = false;
  const Vec3 c(0.05, -0.5, 0.1);
  const double r = 0.2;
  const Sweep s = SimulateSweep(UvSphere(c, r, 400, 200), o, 1);
  const Intrinsics K = o.kinect.intrinsics;
  const Eigen::Isometry3d c2o = s.frames[0].camera_to_object;
  int compared = 0;
  for (int v = 0; v < K.height; v += 3)
    for (int u = 0; u < K.width; u += 3) {
      const Vec3 d = c2o.linear() * PixelRay(K, u, v), oc = c2o.translation() - c;
      // |o + t d − c|² = r²
      const double A = d.squaredNorm(), B = 2 * oc.dot(d), C = oc.squaredNorm() - r * r;
      const double disc = B * B - 4 * A * C;
      const float z = s.frames[0].depth[size_t(v) * K.width + u];
      // Misses must be empty; compare where the incidence cosine is > 0.5 (the
      // tessellation's sagitta, ~1.2e-5 m, grows as 1/cos along the ray).
      if (disc < 0) {
        if (disc < -1e-3 * A) {
          EXPECT_EQ(z, 0.0f) << u << "," << v;
        }
        continue;
      }
      if (std::sqrt(disc) / (2 * r * std::sqrt(A)) < 0.5) continue;
      const double t = (-B - std::sqrt(disc)) / (2 * A);
      EXPECT_NEAR(z, t, 1e-4) << u << "," << v;
      ++compared;
    }
  EXPECT_GT(compared, 1000);
}

TEST(Sweep, GarmentDepthMatchesBruteForceAndBackProjectsOntoSurface) {
  SweepOptions o;
  o.frames = 4;
  o.kinect.noise = false;  // scene on: background present, garment in front
  const TriMesh sheet = WavySheet();
  const Sweep s = SimulateSweep(sheet, o, 1);
  const Intrinsics K = o.kinect.intrinsics;
  int garment = 0;
  for (int i = 0; i < 4; ++i) {
    const DepthFrame& f = s.frames[i];
    for (int v = 0; v < K.height; v += 7)
      for (int u = 0; u < K.width; u += 7) {
        const Vec3 d = f.camera_to_object.linear() * PixelRay(K, u, v);
        const double t = BruteHit(sheet, f.camera_to_object.translation(), d);
        const float z = f.depth[size_t(v) * K.width + u];
        if (!std::isfinite(t)) continue;
        // The gripper may cover the sheet's top: only compare where the depth is the sheet's.
        if (std::abs(z - t) > 1e-3 && z < t) continue;
        EXPECT_NEAR(z, t, 1e-4) << "frame " << i << " pixel " << u << "," << v;
        const Vec3 p_obj = f.camera_to_object * (PixelRay(K, u, v) * double(z));
        EXPECT_LT(DistanceToMesh(sheet, p_obj), 1e-4);
        ++garment;
      }
  }
  EXPECT_GT(garment, 500);
  EXPECT_GT(s.stats.garment_pixels_mean, 10000);
  EXPECT_TRUE(s.stats.warnings.empty());
}

TEST(Sweep, FrameAtAngleSeesTheObjectTurned) {
  // An off-axis box (object +x): turned by θ it must look like the box pre-turned by θ.
  const TriMesh box = Box({0.2, -0.6, -0.05}, {0.35, -0.3, 0.05});
  SweepOptions o = Flat();
  o.frames = 8;
  const Sweep s = SimulateSweep(box, o, 3);
  for (int i = 0; i < 8; ++i) {
    const double a = FrameAngle(o, i);
    EXPECT_NEAR(a, 2 * M_PI * i / 8, 1e-12);
    TriMesh turned = box;
    const Eigen::Matrix3d R = Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix();
    for (int k = 0; k < turned.NumVertices(); ++k) turned.V.row(k) = (R * box.V.row(k).transpose()).transpose();
    SweepOptions o1 = Flat();
    const Sweep ref = SimulateSweep(turned, o1, 3);
    // Same depth everywhere but on a few silhouette pixels (float rounding of turned
    // vertices vs turned rays decides edge hits).
    int box = 0, differ = 0;
    for (size_t p = 0; p < ref.frames[0].depth.size(); ++p) {
      const float a = s.frames[i].depth[p], b = ref.frames[0].depth[p];
      box += (a > 0 || b > 0);
      if ((a > 0) != (b > 0)) {
        ++differ;
        continue;
      }
      ASSERT_NEAR(a, b, 2e-5) << "frame " << i << " pixel " << p;
    }
    EXPECT_GT(box, 1000);
    EXPECT_LT(differ, box / 100 + 3) << "frame " << i;
  }
  // At 0 the box is right of the image centre, at 180° left; at 90° it is farther than at 270°.
  const Intrinsics K = o.kinect.intrinsics;
  auto centroid = [&](const DepthFrame& f, double* mean_z) {
    double su = 0, sz = 0;
    int n = 0;
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u)
        if (float z = f.depth[size_t(v) * K.width + u]; z > 0) su += u, sz += z, ++n;
    *mean_z = sz / n;
    return su / n;
  };
  double z0, z2, z4, z6;
  EXPECT_GT(centroid(s.frames[0], &z0), K.cx + 50);
  EXPECT_LT(centroid(s.frames[4], &z4), K.cx - 50);
  centroid(s.frames[2], &z2);
  centroid(s.frames[6], &z6);
  EXPECT_GT(z2, z6 + 0.4);
}

TEST(Sweep, CameraPosesAreTheTurnedGripperFrame) {
  SweepOptions o;
  o.frames = 12;
  o.kinect.noise = false;
  const Sweep s = SimulateSweep(WavySheet(4, 4), o, 1);
  const Eigen::Isometry3d c2w = CameraToWorld(o);
  // The optical axis crosses the turning axis at look_at_height.
  const Vec3 cam = c2w.translation(), axis = c2w.linear().col(2);
  const double t = -cam.z() / axis.z();
  EXPECT_NEAR((cam + t * axis).y(), o.look_at_height, 1e-12);
  EXPECT_NEAR(cam.y(), 1.2, 1e-12);
  EXPECT_NEAR((c2w.linear().transpose() * c2w.linear() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(c2w.linear().determinant(), 1, 1e-12);
  for (int i = 0; i < 12; ++i) {
    const double th = 2 * M_PI * i / 12;
    Eigen::Isometry3d expect = Eigen::Isometry3d::Identity();
    expect.rotate(Eigen::AngleAxisd(-th, Vec3::UnitY()));
    expect.translate(Vec3(0, -o.gripper_height, 0));
    expect = expect * c2w;
    EXPECT_NEAR((s.frames[i].camera_to_object.matrix() - expect.matrix()).norm(), 0, 1e-12);
    EXPECT_NEAR((s.frames[i].camera_to_world.matrix() - c2w.matrix()).norm(), 0, 1e-15);
    EXPECT_NEAR(s.frames[i].gripper_angle, th, 1e-12);
    // The camera stays at its height in the object frame and circles the axis.
    const Vec3 p = s.frames[i].camera_to_object.translation();
    EXPECT_NEAR(p.y(), 1.2 - o.gripper_height, 1e-12);
    EXPECT_NEAR(std::hypot(p.x(), p.z()), o.camera_distance, 1e-12);
  }
}

TEST(Sweep, BackAndForthAngles) {
  SweepOptions o;
  o.frames = 550;
  o.back_and_forth = true;
  EXPECT_NEAR(FrameAngle(o, 0), 0, 1e-15);
  EXPECT_NEAR(FrameAngle(o, 275), 2 * M_PI, 1e-12);
  EXPECT_NEAR(FrameAngle(o, 549), 2 * M_PI / 275, 1e-12);
  EXPECT_NEAR(FrameAngle(o, 100), FrameAngle(o, 450), 1e-12);
  double prev = -1;
  for (int i = 0; i <= 275; ++i) EXPECT_GT(FrameAngle(o, i), prev), prev = FrameAngle(o, i);
}

double SigmaZ(double z) { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }

TEST(KinectNoise, AxialStdMatchesNguyen) {
  for (bool quantize : {false, true})
    for (double D : {1.0, 2.0}) {
      SweepOptions o = Flat(true);
      o.kinect.quantize = quantize;
      const Sweep s = SimulateSweep(Quad(-5, 5, -5, 5, o.camera_distance - D), o, 7);
      std::vector<double> e;
      for (float z : s.frames[0].depth)
        if (z > 0) e.push_back(z - D);
      ASSERT_GT(e.size(), 300000u);  // a fronto-parallel plane has no dropouts
      double mean;
      const double sd = Std(e, &mean);
      EXPECT_NEAR(sd, SigmaZ(D), 0.15 * SigmaZ(D)) << "D " << D << " quantize " << quantize;
      EXPECT_LT(std::abs(mean), 0.3 * SigmaZ(D)) << "D " << D;
      std::printf("plane at %.1f m, quantize %d: std %.5f m (Nguyen %.5f m), mean error %+.5f m\n", D, int(quantize),
                  sd, SigmaZ(D), mean);
    }
}

TEST(KinectNoise, DisparityQuantisationSteps) {
  // A slanted plane with only quantisation: every depth is b·f/(k/8), k integer, and the
  // steps between distinct depths are ≈ Z²/348 m (Khoshelham & Elberink).
  SweepOptions o = Flat(true);
  o.kinect.axial = o.kinect.lateral = o.kinect.dropouts = false;
  TriMesh plane = Quad(-5, 5, -5, 5, 0);
  for (int k = 0; k < 4; ++k) plane.V(k, 2) = o.camera_distance - 2.0 + 0.3 * plane.V(k, 0);  // z varies with x
  const Sweep s = SimulateSweep(plane, o, 1);
  std::set<float> values;
  const double bf = 0.075 * 580;
  for (float z : s.frames[0].depth) {
    if (z <= 0) continue;
    const double k = bf / z / 0.125;
    ASSERT_NEAR(k, std::round(k), 1e-3);
    values.insert(z);
  }
  ASSERT_GT(values.size(), 20u);
  std::vector<float> v(values.begin(), values.end());
  for (size_t i = 1; i < v.size(); ++i) {
    const double zm = 0.5 * (v[i] + v[i - 1]);
    EXPECT_NEAR(v[i] - v[i - 1], zm * zm / 348.0, 0.02 * zm * zm / 348.0);
  }
}

TEST(KinectNoise, GrazingAnglesAndShadowsDropOut) {
  // A plane turned ~80° from the view: incidence angles 50–87° across the image. Only
  // grazing dropouts on: none below 75°, all beyond 85°, a linear ramp in between.
  SweepOptions o = Flat(true);
  o.kinect.axial = o.kinect.lateral = o.kinect.quantize = o.kinect.projector_shadow = false;
  o.kinect.edge_dropout_probability = 0;
  TriMesh plane = Quad(-3, 3, -3, 3, 0);
  const double a = 80 * M_PI / 180;
  for (int k = 0; k < 4; ++k) {
    const double x = plane.V(k, 0);
    plane.V(k, 0) = x * std::cos(a);
    plane.V(k, 2) = o.camera_distance - 2.0 - x * std::sin(a);
  }
  SweepScene grazing_scene(plane, o);
  const ExactFrame ex = grazing_scene.RenderExact(0);
  Rng rng(11);
  const std::vector<float> z = ApplyKinectNoise(ex, o.kinect, rng);
  int low = 0, low_ok = 0, high = 0, high_ok = 0, mid = 0, mid_ok = 0;
  for (size_t p = 0; p < z.size(); ++p) {
    if (!(ex.depth[p] >= 0.5f && ex.depth[p] <= 4.0f)) continue;
    const double th = std::acos(double(ex.cos_incidence[p])) * 180 / M_PI;
    if (th < 74.9) low++, low_ok += z[p] > 0;
    if (th > 85.1) high++, high_ok += z[p] > 0;
    if (th > 79 && th < 81) mid++, mid_ok += z[p] > 0;
  }
  ASSERT_GT(low, 1000);
  ASSERT_GT(high, 200);
  ASSERT_GT(mid, 1000);
  EXPECT_EQ(low_ok, low);
  EXPECT_EQ(high_ok, 0);
  EXPECT_NEAR(double(mid_ok) / mid, 0.5, 0.05);

  // Projector shadow: a near board in front of a far wall leaves a band with no data on
  // its left, ≈ b·f·(1/z_near − 1/z_far) px wide.
  TriMesh scene = Quad(-5, 5, -5, 5, o.camera_distance - 2.5);
  const TriMesh board = Quad(0.0, 0.3, -0.5, 0.5, o.camera_distance - 1.0);
  scene.V.conservativeResize(8, 3);
  scene.V.bottomRows(4) = board.V;
  scene.F.conservativeResize(4, 3);
  scene.F.bottomRows(2) = board.F.array() + 4;
  SweepOptions so = Flat(true);
  so.kinect.axial = so.kinect.lateral = so.kinect.quantize = false;
  so.kinect.edge_dropout_probability = 0;
  const Sweep sh = SimulateSweep(scene, so, 1);
  const Intrinsics K = so.kinect.intrinsics;
  const int v = int(K.cy);
  const int left = int(std::ceil(K.cx));  // board's left edge at x = 0
  int band = 0;
  for (int u = left - 1; u >= 0 && sh.frames[0].depth[size_t(v) * K.width + u] == 0; --u) ++band;
  const double expect = 0.075 * K.fx * (1 / 1.0 - 1 / 2.5);
  EXPECT_NEAR(band, expect, 2.0);
  // Right of the board: no shadow.
  const int right = int(K.cx + K.fx * 0.3 / 1.0) + 2;
  EXPECT_GT(sh.frames[0].depth[size_t(v) * K.width + right], 2.0f);
}

TEST(KinectNoise, SweepPlanCacheGivesTheSameFramesAsTheFullModel) {
  // RenderKinect re-plans only the garment's region: it must equal noise on the whole
  // exact frame, byte for byte, with the full scene (shadows, edges at the region border).
  SweepOptions o;
  SweepScene scene(WavySheet(), o);
  KinectScratch scratch;  // reused across angles, as in a sweep
  for (double a : {0.0, 1.0, 2.5, 4.0, 5.5, 1.0}) {
    Rng r1(17), r2(17);
    const std::vector<float> fast = scene.RenderKinect(a, r1, &scratch);
    const std::vector<float> full = ApplyKinectNoise(scene.RenderExact(a), o.kinect, r2);
    ASSERT_EQ(fast.size(), full.size());
    int diff = 0;
    for (size_t p = 0; p < fast.size(); ++p) diff += fast[p] != full[p];
    EXPECT_EQ(diff, 0) << "angle " << a;
  }
}

TEST(KinectNoise, DeterministicPerSeedAndThreadCount) {
  SweepOptions o;
  o.frames = 6;
  const TriMesh sheet = WavySheet();
  const auto a = EncodeSweep(SimulateSweep(sheet, o, 42));
  const auto b = EncodeSweep(SimulateSweep(sheet, o, 42));
  o.threads = 2;
  const auto c = EncodeSweep(SimulateSweep(sheet, o, 42));
  const auto d = EncodeSweep(SimulateSweep(sheet, o, 43));
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].first, b[i].first);
    EXPECT_TRUE(a[i].second == b[i].second) << a[i].first;
    EXPECT_TRUE(a[i].second == c[i].second) << a[i].first;
  }
  for (int i = 0; i < 6; ++i) EXPECT_FALSE(a[i].second == d[i].second) << a[i].first;
}

TEST(SweepIo, RoundTripThroughFiles) {
  SweepOptions o;
  o.frames = 5;
  o.kinect.edge_jump = 0.05;
  const Sweep s = SimulateSweep(WavySheet(), o, 9);
  const auto files = EncodeSweep(s);
  ASSERT_EQ(files.size(), 5u + 4u);
  EXPECT_EQ(files[0].first, "sweep/000000.png");
  EXPECT_EQ(files[5].first, "sweep/cameras.json");
  const auto dir = std::filesystem::temp_directory_path() / ("drape_sweep_test_" + std::to_string(::getpid()));
  for (const auto& [path, bytes] : files) WriteFileAtomic(dir / path, bytes);
  const Sweep r = ReadSweep(dir / "sweep");
  ASSERT_EQ(r.frames.size(), 5u);
  EXPECT_EQ(r.intrinsics.width, 640);
  EXPECT_EQ(r.intrinsics.fx, 525);
  EXPECT_EQ(r.seed, 9u);
  EXPECT_EQ(r.options.kinect.edge_jump, 0.05);
  EXPECT_EQ(r.options.camera_distance, o.camera_distance);
  for (int i = 0; i < 5; ++i) {
    EXPECT_NEAR((r.frames[i].camera_to_object.matrix() - s.frames[i].camera_to_object.matrix()).norm(), 0, 1e-15);
    EXPECT_EQ(r.frames[i].gripper_angle, s.frames[i].gripper_angle);
    for (size_t p = 0; p < s.frames[i].depth.size(); ++p) {
      const double z = s.frames[i].depth[p];
      ASSERT_NEAR(r.frames[i].depth[p], std::round(z * 1000) / 1000, 1e-6);
    }
  }
  // Re-encoding what was read gives the same PNG bytes (depth already on the mm grid).
  const auto again = EncodeSweep(r);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(again[i].second == files[i].second);
  // cameras.json: 4×4 row-major camera_to_object.
  const Json j = Json::parse(files[5].second);
  EXPECT_EQ(j["depth_scale"].get<double>(), 1000.0);
  EXPECT_NEAR(j["frames"][2]["camera_to_object"][3].get<double>(), s.frames[2].camera_to_object.translation().x(),
              1e-15);
  EXPECT_EQ(j["frames"][2]["camera_to_object"][12].get<double>(), 0.0);
  std::filesystem::remove_all(dir);
  EXPECT_THROW(ReadSweep(dir / "missing"), Error);
}

TEST(SweepIo, PreviewIsAColourPng) {
  SweepOptions o;
  o.frames = 1;
  const Sweep s = SimulateSweep(WavySheet(), o, 1);
  const std::string png = RenderDepthPreview(s.frames[0], s.intrinsics);
  const cv::Mat m =
      cv::imdecode(cv::Mat(1, int(png.size()), CV_8UC1, const_cast<char*>(png.data())), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(m.empty());
  EXPECT_EQ(m.type(), CV_8UC3);
  EXPECT_EQ(m.rows, 480);
  EXPECT_GT(m.cols, 640);
  EXPECT_EQ(png, RenderDepthPreview(s.frames[0], s.intrinsics));
}

TEST(SweepScene, IrRangeAlongRay) {
  const SweepOptions o = Flat();
  // Quad at object z = 0.1, i.e. world z = 0.1 (object frame origin at the gripper).
  SweepScene scene(Quad(-1, 1, -1, 0, 0.1), o);
  const Vec3 origin(0.0, o.gripper_height - 0.5, 0.25);
  IrRangeOptions ir;
  EXPECT_NEAR(scene.RangeAlongRay(origin, Vec3(0, 0, -2), 0.0, ir), 0.15, 1e-6);
  // Turned by 180° the quad is at world z = −0.1.
  EXPECT_NEAR(scene.RangeAlongRay(origin, Vec3(0, 0, -1), M_PI, ir), 0.35, 1e-6);
  EXPECT_TRUE(std::isinf(scene.RangeAlongRay(origin, Vec3(0, 0, 1), 0.0, ir)));
  EXPECT_TRUE(std::isinf(scene.RangeAlongRay(origin + Vec3(0, 0, 0.5), Vec3(0, 0, -1), 0.0, ir)));  // 0.65 m > max
  Rng rng(5);
  std::vector<double> r;
  r.reserve(4000);
  for (int i = 0; i < 4000; ++i) r.push_back(scene.RangeAlongRay(origin, Vec3(0, 0, -1), 0.0, ir, &rng));
  double mean;
  const double sd = Std(r, &mean);
  EXPECT_NEAR(mean, 0.15, 1e-4);
  EXPECT_NEAR(sd, 0.001 + 0.01 * 0.15, 0.1 * 0.0025);
}

TEST(SweepOptions, ValidateNamesTheField) {
  SweepOptions o;
  o.frames = 0;
  try {
    o.Validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sweep.frames"), std::string::npos);
  }
  o = SweepOptions();
  o.kinect.max_range = 0.1;
  EXPECT_THROW(o.Validate(), Error);
  o = SweepOptions();
  o.embree_isa = "neon";
  EXPECT_THROW(o.Validate(), Error);
  EXPECT_THROW(SimulateSweep(TriMesh(), SweepOptions(), 1), Error);
}

// A crumpled sheet of small triangles: many rays graze edges and pass near-coincident
// layers, where an inexact intersector's last bits and edge decisions show.
TriMesh CrumpledSheet() {
  TriMesh m = WavySheet(80, 140);
  for (int i = 0; i < m.NumVertices(); ++i) {
    const double x = m.V(i, 0), y = m.V(i, 1);
    m.V(i, 2) += 0.04 * std::sin(40 * x + 13 * y) * std::cos(23 * y);
  }
  return m;
}

TEST(SweepScene, DepthBytesAreTheSameOnEveryIsa) {
  // Embree's own triangle tests divide by an approximate reciprocal whose bits differ
  // between ISAs and CPU makers; ours decide in double (scene.cpp), so every ISA this
  // CPU has gives the same bytes as SSE2, which every x86-64 CPU has.
  SweepOptions o;
  o.kinect.noise = false;
  const TriMesh sheet = CrumpledSheet();
  std::vector<ExactFrame> reference;
  double reference_range = 0;
  int compared = 0;
  for (const char* isa : {"sse2", "sse4.2", "avx", "avx2", "avx512", ""}) {
    o.embree_isa = isa;
    std::unique_ptr<SweepScene> scene;
    try {
      scene = std::make_unique<SweepScene>(sheet, o);
    } catch (const Error&) {
      continue;  // this CPU lacks the ISA
    }
    std::vector<ExactFrame> frames;
    for (double a : {0.0, 1.3, 2.9, 4.4}) frames.push_back(scene->RenderExact(a));
    const double range =
        scene->RangeAlongRay(Vec3(0.013, o.gripper_height - 0.41, 0.3), Vec3(0.02, 0.01, -1), 0.7, IrRangeOptions());
    if (reference.empty()) {
      reference = frames;
      reference_range = range;
      EXPECT_GT(frames[0].garment_pixels, 20000);
      EXPECT_TRUE(std::isfinite(range));
      continue;
    }
    for (size_t k = 0; k < frames.size(); ++k) {
      EXPECT_EQ(frames[k].depth, reference[k].depth) << "isa " << isa << ", frame " << k;
      EXPECT_EQ(frames[k].cos_incidence, reference[k].cos_incidence) << "isa " << isa << ", frame " << k;
      EXPECT_EQ(frames[k].garment_pixels, reference[k].garment_pixels) << "isa " << isa << ", frame " << k;
    }
    EXPECT_EQ(range, reference_range) << "isa " << isa;
    ++compared;
  }
  EXPECT_GE(compared, 2);  // sse4.2 and "" at least
}

TEST(SweepScene, NoRayPassesBetweenTriangles) {
  // A plane cut into thin slivers that all meet at a few vertices: every pixel whose ray
  // meets the plane inside its border hits it (a watertight test has no cracks on
  // shared edges), at the plane's depth.
  const SweepOptions o = Flat();
  const double D = 1.2, z0 = o.camera_distance - D;
  TriMesh fan;
  const int n = 720;
  fan.V.resize(n + 1, 3);
  fan.V.row(0) << 0.013, o.camera_height - o.gripper_height + 0.007, z0;  // the fan's centre, near the optical axis
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    fan.V.row(i + 1) << fan.V(0, 0) + 3 * std::cos(a), fan.V(0, 1) + 3 * std::sin(a), z0;
  }
  fan.F.resize(n, 3);
  for (int i = 0; i < n; ++i) fan.F.row(i) << 0, i + 1, (i + 1) % n + 1;
  const Sweep s = SimulateSweep(fan, o, 1);
  const auto& z = s.frames[0].depth;
  for (size_t p = 0; p < z.size(); ++p) ASSERT_NEAR(z[p], D, 1e-4) << "pixel " << p;
}

TEST(SweepScene, RoiCoversEveryGarmentPixel) {
  // Brute force: with the ROI forced to the full image the frame is the same.
  SweepOptions o;
  o.kinect.noise = false;
  const TriMesh sheet = WavySheet(10, 16);
  SweepScene scene(sheet, o);
  for (double a : {0.0, 0.7, 2.0, 4.1}) {
    const ExactFrame f = scene.RenderExact(a);
    const PixelRect r = scene.Roi(a);
    EXPECT_LT(r.Area(), 640 * 480 / 2);
    const Intrinsics K = o.kinect.intrinsics;
    const Eigen::Isometry3d c2o = ObjectToWorld(o, a).inverse() * CameraToWorld(o);
    for (int v = 0; v < K.height; v += 3)
      for (int u = 0; u < K.width; u += 3) {
        if (u >= r.u0 && u < r.u1 && v >= r.v0 && v < r.v1) continue;
        const double t = BruteHit(sheet, c2o.translation(), c2o.linear() * PixelRay(K, u, v));
        ASSERT_TRUE(std::isinf(t)) << "garment pixel outside the ROI at " << u << "," << v;
      }
    EXPECT_GT(f.garment_pixels, 1000);
  }
}

}  // namespace
}  // namespace drape
