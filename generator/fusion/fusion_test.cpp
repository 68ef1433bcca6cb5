#include "generator/fusion/fusion.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <bit>
#include <cmath>

#include "common/error.h"
#include "common/rng.h"
#include "generator/fusion/synthetic.h"
#include "generator/fusion/tsdf_impl.h"
#include "generator/sweep/sweep.h"

namespace drape {
namespace {

using synthetic::Scene;
using synthetic::Shape;

using synthetic::SmallCamera;

// Bit for bit (NaNs and -0 included): the vectorised kernels must reproduce the scalar
// ones exactly, which == on floats cannot say.
bool SameBits(const float* a, const float* b, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (std::bit_cast<uint32_t>(a[i]) != std::bit_cast<uint32_t>(b[i])) return false;
  return true;
}

double SignedVolume(const TriMesh& m) {
  double v = 0;
  for (int f = 0; f < m.NumFaces(); ++f) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    v += a.dot(b.cross(c)) / 6;
  }
  return v;
}

int BoundaryEdges(const TriMesh& m) {
  int n = 0;
  for (const auto& e : BuildEdgeTopology(m).edges) n += e.faces[1] < 0;
  return n;
}

std::string MeshBytes(const TriMesh& m) {
  std::string s(reinterpret_cast<const char*>(m.V.data()), sizeof(double) * m.V.size());
  s.append(reinterpret_cast<const char*>(m.F.data()), sizeof(int) * m.F.size());
  return s;
}

constexpr double kSignMargin = 0.006;
// The diagonal of an 8³-voxel block, in voxels.
const double kBlockDiagonalVoxels = 8 * std::sqrt(3.0);
const Shape kSphere = Shape::Sphere(Vec3(0.02, -0.4, -0.01), 0.15);

struct Fused {
  FusionResult result;
  Scene scene;
};

FusionResult Fuse(const Scene& scene, double noise, int frames = 60, int threads = 1, uint64_t seed = 7) {
  synthetic::TurntableOptions t;
  t.frames = frames;
  t.noise_sigma = noise;
  t.seed = seed;
  const Intrinsics K = SmallCamera();
  FusionOptions o;
  o.threads = threads;
  o.frames_stride = 1;
  return FuseFrames(synthetic::RenderTurntable(scene, K, t), K, o, seed);
}

TEST(Fusion, SynthesisedMeshesAreOutwardAndClosed) {
  for (const auto& s :
       {kSphere, Shape::Box(Vec3(0, -0.5, 0), Vec3(0.1, 0.2, 0.05)), Shape::Cylinder(Vec3(0, -0.5, 0), 0.1, 0.2)}) {
    const TriMesh m = synthetic::MeshShape(s, 4);
    EXPECT_GT(SignedVolume(m), 0);
    EXPECT_EQ(BoundaryEdges(m), 0);
  }
}

// Best cosine between the outward normal at the sphere's surface point nearest p and
// the direction to a camera of Fuse's turntable (TurntableOptions' defaults: 60 views
// on a circle of radius 1.2 m at y = 0, above the sphere); <= 0: no view sees it.
double BestViewCosine(const Shape& sphere, const Vec3& p) {
  const synthetic::TurntableOptions t;
  const Vec3 n = (p - sphere.center).normalized();
  const Vec3 s = sphere.center + sphere.half.x() * n;
  double best = -1;
  for (int i = 0; i < t.frames; ++i) {
    const double phi = 2 * M_PI * i / t.frames;
    const Vec3 eye(t.distance * std::sin(phi), t.camera_y, t.distance * std::cos(phi));
    best = std::max(best, n.dot((eye - s).normalized()));
  }
  return best;
}

TEST(Fusion, SphereSdfSignAndValues) {
  const Scene scene{{kSphere}};
  const FusionResult r = Fuse(scene, 0);
  const double mu = FusionOptions().Truncation();
  const double h = FusionOptions().VoxelSize();
  // Where the sign is known only to a block: within a block's diagonal of surface that
  // no view sees, or sees only at grazing incidence (cosine < 0.3: the cameras look
  // down on the sphere, so this is its underside). There a surface block's observed
  // voxels are all in front of the surface: behind a surface seen at incidence θ the
  // projective distance reaches -μ after μ·cos θ (< 1.2 voxels here), so too few views
  // observe that side to reach min_weight, and rule 2 (fusion.h) gives the block's
  // unobserved interior voxels the sign of its nearest observed voxel, outside; rule 3
  // carves at block centres. Measured over 300,000 points (10 seeds): 74 had the wrong
  // sign (up to 1.3 cm inside), every one where the best cosine is below 0.25; this
  // zone holds ~1.6 % of the points. (Before the draws were sequenced, gcc and clang
  // sampled different points from the same seed, and only clang's set hit one.)
  const double block_diagonal = kBlockDiagonalVoxels * h;
  Rng rng(3);
  int checked_near = 0, good_near = 0, coarse = 0, coarse_wrong = 0;
  for (int i = 0; i < 3000; ++i) {
    const double px = rng.Uniform(-0.3, 0.3), py = rng.Uniform(-0.3, 0.3), pz = rng.Uniform(-0.3, 0.3);
    const Vec3 p = kSphere.center + Vec3(px, py, pz);
    const double truth = kSphere.Sdf(p);
    const double got = r.tsdf->Sdf(p);
    if (std::abs(truth) < block_diagonal && BestViewCosine(kSphere, p) < 0.3) {
      ++coarse;
      coarse_wrong += (truth < -kSignMargin && got >= 0) || (truth > kSignMargin && got <= 0);
    } else {
      // Elsewhere the sign is right away from the surface (including the interior
      // that no ray reaches, deeper than the truncation band), beyond ~1.3 pixel
      // footprints (4.6 mm at 1.2 m here): a pixel's precision.
      if (truth < -kSignMargin) {
        EXPECT_LT(got, 0) << "inside at " << p.transpose() << " truth " << truth;
      }
      if (truth > kSignMargin) {
        EXPECT_GT(got, 0) << "outside at " << p.transpose() << " truth " << truth;
      }
    }
    // Near the surface the fused distance follows the true one: the projective
    // distance along rays overestimates |sdf| away from the zero crossing, so the
    // bound is on points within half the band.
    if (std::abs(truth) < 0.5 * mu) {
      ++checked_near;
      good_near += std::abs(got - truth) < 2 * h;
    }
  }
  EXPECT_GT(checked_near, 20);
  // Within two voxels at 80 % of near-surface points (the projective distance along
  // rays overestimates |sdf| at grazing views).
  EXPECT_GE(good_near, 0.8 * checked_near) << "near-surface error";
  // The block-resolution zone: nearly all right (measured 1 of 48 wrong here).
  EXPECT_GT(coarse, 0);
  EXPECT_LE(coarse_wrong, 0.1 * coarse) << "of " << coarse << " points in the block-resolution zone";
  EXPECT_LT(r.tsdf->Sdf(kSphere.center), 0);
  EXPECT_NEAR(r.tsdf->Sdf(kSphere.center), -mu, 1e-6);  // unobserved interior
  EXPECT_NEAR(r.tsdf->Sdf(kSphere.center + Vec3(0.3, 0, 0)), mu, 1e-6);
  EXPECT_GT(r.stats.inside_blocks, 0);
  std::printf(
      "sphere: %d of %d near-surface points within two voxels; %d of %d points in the "
      "block-resolution zone with the wrong sign\n",
      good_near, checked_near, coarse_wrong, coarse);
}

TEST(Fusion, BoxSdfSign) {
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.4, Vec3::UnitY()).toRotationMatrix() *
                              Eigen::AngleAxisd(0.2, Vec3::UnitX()).toRotationMatrix();
  const Shape box = Shape::Box(Vec3(0, -0.45, 0.02), Vec3(0.12, 0.25, 0.08), rot);
  const Scene scene{{box}};
  const FusionResult r = Fuse(scene, 0);
  Rng rng(5);
  int wrong = 0, n = 0;
  for (int i = 0; i < 3000; ++i) {
    const double px = rng.Uniform(-0.35, 0.35), py = rng.Uniform(-0.35, 0.35), pz = rng.Uniform(-0.35, 0.35);
    const Vec3 p = box.center + Vec3(px, py, pz);
    const double truth = box.Sdf(p);
    if (std::abs(truth) < kSignMargin) continue;
    ++n;
    wrong += (truth < 0) != (r.tsdf->Sdf(p) < 0);
  }
  // Measured 3 of ~2900, at the box's edges where silhouettes of two faces meet.
  EXPECT_LE(wrong, n / 200) << "of " << n;
  EXPECT_LT(r.tsdf->Sdf(box.center), 0);
}

// Two layers 1 cm apart joined at their edges, like the front and back of a shirt:
// the space between them reads inside.
TEST(Fusion, ThinTwoLayerInteriorReadsInside) {
  const Shape slab = Shape::Box(Vec3(0, -0.45, 0), Vec3(0.2, 0.3, 0.006));
  const FusionResult r = Fuse(Scene{{slab}}, 0);
  int inside = 0, n = 0;
  for (double x = -0.15; x <= 0.15; x += 0.03) {
    for (double y = -0.7; y <= -0.2; y += 0.05) {
      ++n;
      inside += r.tsdf->Sdf(Vec3(x, y, 0)) < 0;
    }
  }
  EXPECT_EQ(inside, n);
  EXPECT_GT(r.tsdf->Sdf(Vec3(0, -0.45, 0.02)), 0);
  EXPECT_GT(r.tsdf->Sdf(Vec3(0, -0.45, -0.02)), 0);
}

// Prints the sphere's accuracy and checks it against the bounds both sphere tests share.
void ExpectSphereAccuracy(const char* label, const Accuracy& a) {
  std::printf("sphere %s: recon->truth mean %.3f p95 %.3f mm, truth->recon mean %.3f p95 %.3f mm\n", label,
              a.recon_to_truth_mean * 1e3, a.recon_to_truth_p95 * 1e3, a.truth_to_recon_mean * 1e3,
              a.truth_to_recon_p95 * 1e3);
  EXPECT_LT(a.recon_to_truth_mean, 0.0015);
  EXPECT_LT(a.recon_to_truth_p95, 0.008);
  EXPECT_LT(a.truth_to_recon_mean, 0.001);
  EXPECT_LT(a.truth_to_recon_p95, 0.003);
}

TEST(Fusion, SphereMeshAccuracyNoiseFree) {
  const FusionResult r = Fuse(Scene{{kSphere}}, 0);
  ASSERT_GT(r.mesh.NumFaces(), 1000);
  EXPECT_EQ(BoundaryEdges(r.mesh), 0);
  EXPECT_GT(SignedVolume(r.mesh), 0) << "faces must be counter-clockwise seen from outside";
  const double true_volume = 4.0 / 3 * M_PI * std::pow(kSphere.half.x(), 3);
  EXPECT_NEAR(SignedVolume(r.mesh), true_volume, 0.02 * true_volume);
  // Measured 1.1 / 6.5 / 0.57 / 2.2 mm: the p95 comes from the bottom cap, which the
  // camera (at the gripper's height, above) never sees; carving bounds it only at
  // block resolution (2 cm) and where a share of the views sees free space below.
  ExpectSphereAccuracy("noise-free", MeasureAccuracy(r.mesh, synthetic::MeshShape(kSphere, 6)));
}

// Faces that repeat a vertex (collapsed marching-cubes quads): assimp rejects them.
int RepeatedVertexFaces(const TriMesh& m) {
  int n = 0;
  for (int f = 0; f < m.NumFaces(); ++f)
    n += m.F(f, 0) == m.F(f, 1) || m.F(f, 1) == m.F(f, 2) || m.F(f, 0) == m.F(f, 2);
  return n;
}

TEST(Fusion, SphereMeshAccuracyNoisy) {
  const FusionResult r = Fuse(Scene{{kSphere}}, 0.002);
  EXPECT_EQ(RepeatedVertexFaces(r.mesh), 0);
  // Measured 1.1 / 6.0 / 0.60 / 2.2 mm: 60 frames average the noise down to the
  // noise-free figures (same cap limitation).
  ExpectSphereAccuracy("sigma=2mm", MeasureAccuracy(r.mesh, synthetic::MeshShape(kSphere, 6)));
}

TEST(Fusion, SegmentationDropsGripperAndDistractor) {
  const Shape gripper = Shape::Box(Vec3(0, 0.03, 0), Vec3(0.04, 0.04, 0.02));
  const Shape distractor = Shape::Sphere(Vec3(0.75, -0.4, 0.0), 0.08);  // outside x ≤ 0.6
  const FusionResult r = Fuse(Scene{{kSphere, gripper, distractor}}, 0);
  const FusionResult clean = Fuse(Scene{{kSphere}}, 0);
  EXPECT_GT(r.tsdf->Sdf(distractor.center), 0);
  EXPECT_GT(r.tsdf->Sdf(gripper.center), 0);
  const Eigen::AlignedBox3d near_sphere(kSphere.center - Vec3::Constant(0.17), kSphere.center + Vec3::Constant(0.17));
  for (int i = 0; i < r.mesh.NumVertices(); ++i)
    ASSERT_TRUE(near_sphere.contains(Vec3(r.mesh.V.row(i)))) << r.mesh.V.row(i);
  const Accuracy a = MeasureAccuracy(r.mesh, synthetic::MeshShape(kSphere, 6));
  EXPECT_LT(a.recon_to_truth_p95, 0.008);
  EXPECT_LT(a.truth_to_recon_p95, 0.003);
  // Nothing else in the scene changes the garment's reconstruction much.
  EXPECT_NEAR(SignedVolume(r.mesh), SignedVolume(clean.mesh), 0.01 * SignedVolume(clean.mesh));
}

TEST(Fusion, DeterministicForAnyThreadCount) {
  const Scene scene{{kSphere, Shape::Box(Vec3(0.1, -0.6, 0), Vec3(0.05, 0.1, 0.2))}};
  std::string vdb1, vdb2, mesh1, mesh2;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const FusionResult r = Fuse(scene, 0.002, 30, 1);
    vdb1 = r.tsdf->EncodeVdb();
    mesh1 = MeshBytes(r.mesh);
  }
  {
    const FusionResult r = Fuse(scene, 0.002, 30, 2);
    vdb2 = r.tsdf->EncodeVdb();
    mesh2 = MeshBytes(r.mesh);
    EXPECT_EQ(r.tsdf->EncodeVdb(), vdb2);
  }
  EXPECT_EQ(vdb1, vdb2);
  EXPECT_EQ(mesh1, mesh2);
  EXPECT_EQ(vdb1.substr(0, 8), std::string("\x20\x42\x44\x56\0\0\0\0", 8));  // OpenVDB magic
}

TEST(Fusion, PoseNoiseIsSeededAndDegradesGracefully) {
  synthetic::TurntableOptions t;
  t.frames = 40;
  const Intrinsics K = SmallCamera();
  const Shape box = Shape::Box(Vec3(0, -0.45, 0), Vec3(0.12, 0.2, 0.06));
  const auto frames = synthetic::RenderTurntable(Scene{{box}}, K, t);
  FusionOptions o;
  o.frames_stride = 1;
  o.pose_noise_degrees = 1.0;
  const FusionResult a = FuseFrames(frames, K, o, 11), b = FuseFrames(frames, K, o, 11),
                     c = FuseFrames(frames, K, o, 12);
  EXPECT_EQ(MeshBytes(a.mesh), MeshBytes(b.mesh));
  EXPECT_NE(MeshBytes(a.mesh), MeshBytes(c.mesh));
  const Accuracy acc = MeasureAccuracy(a.mesh, synthetic::MeshShape(box));
  std::printf("box with 1 deg encoder noise: recon->truth mean %.3f mm, p95 %.3f mm\n", acc.recon_to_truth_mean * 1e3,
              acc.recon_to_truth_p95 * 1e3);
  EXPECT_LT(acc.recon_to_truth_mean, 0.003);
}

TEST(Fusion, OptionsAndFramesAreValidated) {
  FusionOptions o;
  o.voxels_per_metre = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = FusionOptions();
  o.frames_stride = 0;
  try {
    o.Validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frames_stride"), std::string::npos);
  }
  Tsdf tsdf{FusionOptions()};
  DepthFrame bad;
  bad.depth.resize(10);
  EXPECT_THROW(tsdf.Integrate(bad, Intrinsics()), Error);
  std::vector<DepthFrame> frames(3, bad);
  try {
    FuseFrames(frames, Intrinsics(), FusionOptions(), 0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 0"), std::string::npos);
  }
}

TEST(Fusion, EmptyVolume) {
  Tsdf tsdf{FusionOptions()};
  EXPECT_EQ(tsdf.ExtractMesh().NumFaces(), 0);
  EXPECT_GT(tsdf.Sdf(Vec3(0, -0.5, 0)), 0);
  EXPECT_FALSE(tsdf.EncodeVdb().empty());
}

// End to end with the Embree Kinect sweep (noise, dropouts, gripper, arm, table, wall,
// floor): a closed garment-sized slab hanging from the gripper.
TEST(Fusion, KinectSweepOfAHangingSlab) {
  const Shape slab = Shape::Box(Vec3(0.02, -0.36, 0.0), Vec3(0.22, 0.32, 0.04),
                                Eigen::AngleAxisd(0.2, Vec3::UnitY()).toRotationMatrix());
  const TriMesh truth = synthetic::MeshShape(slab);
  SweepOptions so;
  so.frames = 60;
  const Sweep sweep = SimulateSweep(truth, so, 5);
  FusionOptions o;
  o.frames_stride = 1;
  const FusionResult r = FuseFrames(sweep.frames, sweep.intrinsics, o, 5);
  ASSERT_GT(r.mesh.NumFaces(), 1000);
  const Accuracy a = MeasureAccuracy(r.mesh, truth);
  std::printf(
      "kinect sweep (60 frames, noisy): recon->truth mean %.2f p95 %.2f mm, truth->recon mean %.2f p95 %.2f mm; %d "
      "inside blocks\n",
      a.recon_to_truth_mean * 1e3, a.recon_to_truth_p95 * 1e3, a.truth_to_recon_mean * 1e3, a.truth_to_recon_p95 * 1e3,
      r.stats.inside_blocks);
  // Nothing of the scene (gripper, table, wall, floor) enters the reconstruction.
  // (The scene's nearest objects are >= 10 cm away; a few noisy edge pixels that
  // survive fusion lie within 3–4 cm.)
  for (int i = 0; i < r.mesh.NumVertices(); ++i) {
    ASSERT_LT(slab.Sdf(r.mesh.V.row(i)), 0.05) << r.mesh.V.row(i);
    // Above the box top (-0.02) only the fingers (down to -0.015): never in the mesh.
    ASSERT_LT(r.mesh.V(i, 1), -0.015) << r.mesh.V.row(i);
  }
  // Measured 0.95 / 3.0 / 0.75 / 2.1 mm.
  EXPECT_LT(a.recon_to_truth_mean, 0.0015);
  EXPECT_LT(a.recon_to_truth_p95, 0.0045);
  EXPECT_LT(a.truth_to_recon_mean, 0.0012);
  EXPECT_LT(a.truth_to_recon_p95, 0.0035);
  EXPECT_LT(r.tsdf->Sdf(slab.center), 0);
  EXPECT_GT(r.tsdf->Sdf(slab.center + Vec3(0, 0, 0.1)), 0);
}

// Brute force: the distance to every triangle.
std::vector<double> BruteDistances(const Points3& pts, const TriMesh& m) {
  std::vector<double> d(pts.rows(), 1e30);
  for (int i = 0; i < pts.rows(); ++i) {
    const Vec3 p = pts.row(i);
    for (int f = 0; f < m.NumFaces(); ++f) {
      const Vec3 c = ClosestPointOnTriangle(p, m.V.row(m.F(f, 0)), m.V.row(m.F(f, 1)), m.V.row(m.F(f, 2)));
      d[i] = std::min(d[i], (c - p).norm());
    }
  }
  return d;
}

TEST(Fusion, AccuracyMatchesBruteForce) {
  const TriMesh a = synthetic::MeshShape(Shape::Sphere(Vec3(0, 0, 0), 0.1), 2);
  const TriMesh b =
      synthetic::MeshShape(Shape::Box(Vec3(0.01, 0.02, 0), Vec3(0.08, 0.09, 0.07),
                                      Eigen::AngleAxisd(0.3, Vec3(1, 1, 0).normalized()).toRotationMatrix()));
  const Points3 pa = SampleSurface(a, 500, 1);
  const std::vector<double> fast = PointToMeshDistances(pa, b), slow = BruteDistances(pa, b);
  for (size_t i = 0; i < fast.size(); ++i) ASSERT_NEAR(fast[i], slow[i], 1e-12);
  // Samples lie on the mesh and are spread over it by area.
  const std::vector<double> self = BruteDistances(pa, a);
  EXPECT_LT(*std::max_element(self.begin(), self.end()), 1e-12);
  const Accuracy acc = MeasureAccuracy(a, b, 400);
  const Points3 sa = SampleSurface(a, 400, DeriveSeed(0, "fusion/accuracy"));
  const Points3 sb = SampleSurface(b, 400, DeriveSeed(DeriveSeed(0, "fusion/accuracy"), "truth"));
  auto ab = BruteDistances(sa, b), ba = BruteDistances(sb, a);
  double mab = 0, mba = 0;
  for (double d : ab) mab += d / ab.size();
  for (double d : ba) mba += d / ba.size();
  std::sort(ab.begin(), ab.end());
  std::sort(ba.begin(), ba.end());
  EXPECT_NEAR(acc.recon_to_truth_mean, mab, 1e-12);
  EXPECT_NEAR(acc.truth_to_recon_mean, mba, 1e-12);
  EXPECT_NEAR(acc.recon_to_truth_p95, ab[379], 1e-12);  // nearest rank: ceil(0.95·400) = 380
  EXPECT_NEAR(acc.truth_to_recon_p95, ba[379], 1e-12);
  // Identical meshes: zero.
  const Accuracy same = MeasureAccuracy(a, a, 300);
  EXPECT_LT(same.recon_to_truth_p95, 1e-9);
  EXPECT_THROW(MeasureAccuracy(TriMesh{}, a), Error);
}

}  // namespace
}  // namespace drape

namespace drape {
namespace {

// What a fusion holds: stats, .vdb bytes (every voxel's value and weight, every
// unobserved inside tile), mesh bytes, surface points (in order: the feature's
// top-layer mean sums them in order).
struct FusedContent {
  FusionStats stats;
  std::string vdb, mesh;
  Points3 points;
  explicit FusedContent(const Tsdf& t)
      : stats(t.Stats()), vdb(t.EncodeVdb()), mesh(MeshBytes(t.ExtractMesh())), points(t.SurfacePoints()) {}
};

void ExpectSame(const FusedContent& a, const FusedContent& b, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_GT(a.stats.observed_voxels, 1000);
  EXPECT_EQ(a.stats.voxel_updates, b.stats.voxel_updates);
  EXPECT_EQ(a.stats.foreground_pixels, b.stats.foreground_pixels);
  EXPECT_EQ(a.stats.surface_blocks, b.stats.surface_blocks);
  EXPECT_EQ(a.stats.inside_blocks, b.stats.inside_blocks);
  EXPECT_TRUE(a.vdb == b.vdb);
  EXPECT_TRUE(a.mesh == b.mesh);
  ASSERT_EQ(a.points.rows(), b.points.rows());
  EXPECT_TRUE(a.points == b.points);
}

// Fuses the frames with the reference path and the fast path: frame by frame on the
// options' threads, and in batches by FuseFrames on 1 and 3 threads.
void ExpectSameAsReference(const std::vector<DepthFrame>& frames, const Intrinsics& K, const FusionOptions& o) {
  Tsdf fast(o), ref(o);
  for (const auto& f : frames) {
    fast.Integrate(f, K);
    ref.IntegrateReference(f, K);
  }
  const FusedContent expected(ref);
  ExpectSame(FusedContent(fast), expected, "frame by frame");
  for (int threads : {1, 3}) {
    FusionOptions ob = o;
    ob.threads = threads;
    ob.frames_stride = 1;
    const FusionResult r = FuseFrames(frames, K, ob, 1, /*extract_mesh=*/false);
    EXPECT_EQ(r.stats.frames_integrated, static_cast<int>(frames.size()));
    ExpectSame(FusedContent(*r.tsdf), expected, "FuseFrames, " + std::to_string(threads) + " threads");
  }
}

// The Kinect sweep (noise, dropouts, gripper, table, wall, floor) of a garment-like
// two-part object, at the paper's 384 voxels/m and at a coarse 128, with pose noise
// and without the radial limit too.
TEST(Fusion, FastPathMatchesReferenceOnKinectSweeps) {
  const Shape slab = Shape::Box(Vec3(0.02, -0.36, 0.0), Vec3(0.22, 0.32, 0.04),
                                Eigen::AngleAxisd(0.2, Vec3::UnitY()).toRotationMatrix());
  const Shape sleeve =
      Shape::Cylinder(Vec3(0.3, -0.3, 0.02), 0.05, 0.2, Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix());
  TriMesh truth = synthetic::MeshShape(slab);
  synthetic::AppendMesh(truth, synthetic::MeshShape(sleeve));
  SweepOptions so;
  so.frames = 12;  // FuseFrames: a batch of 8 frames and one of 4
  const Sweep sweep = SimulateSweep(truth, so, 9);
  FusionOptions o;
  o.threads = 2;
  ExpectSameAsReference(sweep.frames, sweep.intrinsics, o);
  o.voxels_per_metre = 128;
  o.radius = 0;
  o.hole_radius_px = 3;
  ExpectSameAsReference(sweep.frames, sweep.intrinsics, o);
  // A box reaching behind the camera: the whole image is the region of interest.
  FusionOptions wide;
  wide.voxels_per_metre = 128;
  wide.box = Eigen::AlignedBox3d(Vec3(-2.5, -1.45, -2.5), Vec3(2.5, -0.02, 2.5));
  wide.radius = 0;
  ExpectSameAsReference(sweep.frames, sweep.intrinsics, wide);
}

// Segment's row kernels against the reference's expression (Eigen's R * Vec3(d x̂,
// d ŷ, d) + t, AlignedBox::contains, the radius), with the box faces and the radius put
// exactly on some pixels' points so that ties are decided by the last bit.
TEST(Fusion, SegmentRowKernelsMatchTheReferenceExpression) {
  Rng rng(3);
  const int W = 203;  // not a multiple of 4: the kernels' scalar tails too
  std::vector<double> xhat(W);
  std::vector<float> depth(W), code(W);
  std::vector<uint8_t> fg(W);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Quaterniond q(rng.Normal(), rng.Normal(), rng.Normal(), rng.Normal());
    const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
    const Vec3 t(rng.Uniform(-1, 1), rng.Uniform(-1, 1), rng.Uniform(-2, 2));
    const double yv = rng.Uniform(-0.5, 0.5);
    std::vector<Vec3> p(W);
    for (int u = 0; u < W; ++u) {
      xhat[u] = rng.Uniform(-0.6, 0.6);
      const uint64_t kind = rng.Below(20);
      depth[u] = kind == 0   ? 0.f
                 : kind == 1 ? std::numeric_limits<float>::quiet_NaN()
                 : kind == 2 ? std::numeric_limits<float>::infinity()
                 : kind == 3 ? -1.f
                             : float(rng.Uniform(0.4, 3.0));
      const float d = depth[u];
      p[u] = R * Vec3(d * xhat[u], d * yv, d) + t;
    }
    auto valid = [&](int u) { return depth[u] > 0 && std::isfinite(depth[u]); };
    auto pick = [&] {
      for (;;) {
        const int u = static_cast<int>(rng.Below(W));
        if (valid(u)) return p[u];
      }
    };
    Eigen::AlignedBox3d box;
    box.extend(pick()).extend(pick()).extend(pick());
    const Vec3 pr = pick();
    const double radius2 = trial % 3 == 0 ? 0 : pr.x() * pr.x() + pr.z() * pr.z();
    SegmentRow row;
    row.depth = depth.data(), row.xhat = xhat.data(), row.yv = yv, row.radius2 = radius2;
    row.code = code.data(), row.fg = fg.data();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) row.R[i][j] = R(i, j);
      row.t[i] = t[i], row.lo[i] = box.min()[i], row.hi[i] = box.max()[i];
    }
    for (int kernel = 0; kernel < 3; ++kernel) {
      if ((kernel == 1 && !HaveAvx2()) || (kernel == 2 && !HaveAvx512VlBw())) continue;
      SCOPED_TRACE(kernel == 2 ? "AVX-512" : kernel ? "AVX2" : "scalar");
      std::fill(code.begin(), code.end(), 7.f);
      const int u0 = trial % 5, u1 = W - trial % 3;
      float far = 0, expected_far = 0;
      row.fg_lo = W, row.fg_hi = 0;
      int expected_lo = W, expected_hi = 0;
      const int64_t n = kernel == 2 ? SegmentRowAvx512(row, u0, u1, &far)
                        : kernel    ? SegmentRowAvx2(row, u0, u1, &far)
                                    : SegmentRowScalar(row, u0, u1, &far);
      int64_t expected_n = 0;
      for (int u = u0; u < u1; ++u) {
        const bool in =
            valid(u) && box.contains(p[u]) && (radius2 <= 0 || p[u].x() * p[u].x() + p[u].z() * p[u].z() <= radius2);
        const float expected = !valid(u) ? 0.f : in ? depth[u] : -depth[u];
        ASSERT_TRUE(SameBits(&code[u], &expected, 1))
            << "trial " << trial << " u " << u << ": " << code[u] << " vs " << expected << " depth " << depth[u];
        ASSERT_EQ(fg[u], in) << "trial " << trial << " u " << u;
        expected_n += in;
        if (in)
          expected_far = std::max(expected_far, depth[u]), expected_lo = std::min(expected_lo, u), expected_hi = u + 1;
      }
      EXPECT_EQ(n, expected_n);
      EXPECT_EQ(far, expected_far);
      EXPECT_EQ(row.fg_lo, expected_lo);
      EXPECT_EQ(row.fg_hi, expected_hi);
    }
  }
}

// The vectorised voxel updates against the scalar definition, bit for bit: random
// blocks in front of a small camera (some voxels behind it or off the image), a code
// image of foreground depths near the block, outside-the-box and no-data pixels, NaNs.
TEST(Fusion, UpdateBlockKernelsMatchTheScalarOne) {
  Rng rng(5);
  const int W = 64, H = 48;
  std::vector<float> code(size_t{W} * H);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Quaterniond q(rng.Normal(), rng.Normal(), rng.Normal(), rng.Normal());
    const Eigen::Matrix3f R = q.normalized().toRotationMatrix().cast<float>();
    const float h = float(rng.Uniform(0.002, 0.02));
    VoxelProjector p;
    p.c0 =
        Eigen::Vector3f(float(rng.Uniform(-0.1, 0.1)), float(rng.Uniform(-0.1, 0.1)), float(rng.Uniform(-0.02, 0.6)));
    p.ex = R.col(0) * h, p.ey = R.col(1) * h, p.ez = R.col(2) * h;
    p.fx = p.fy = float(rng.Uniform(40, 80));
    p.cx = W / 2.f, p.cy = H / 2.f;
    p.mu = 4 * h;
    p.W = W, p.H = H;
    const float centre = p.c0.z() + 4 * (p.ex + p.ey + p.ez).z();
    for (float& c : code) {
      const uint64_t kind = rng.Below(10);
      const float d = float(centre + rng.Uniform(-8 * h, 8 * h));
      c = kind == 0 ? 0.f : kind == 1 ? std::numeric_limits<float>::quiet_NaN() : kind == 2 ? -d : d;
    }
    FusionBlock start;
    for (int o = 0; o < kBlockVoxels; ++o) {
      start.weight[o] = float(rng.Below(4));
      start.tsdf[o] = start.weight[o] > 0 ? float(rng.Uniform(-p.mu, p.mu)) : 0.f;
    }
    FusionBlock expected = start;
    const int64_t n = UpdateBlockScalar(expected, p, code.data());
    const std::pair<const char*, int64_t (*)(FusionBlock&, const VoxelProjector&, const float*)> kernels[] = {
        {"AVX2", HaveAvx2() ? UpdateBlockAvx2 : nullptr}, {"AVX-512", HaveAvx512() ? UpdateBlockAvx512 : nullptr}};
    for (const auto& [name, kernel] : kernels) {
      if (!kernel) continue;
      SCOPED_TRACE(std::string(name) + ", trial " + std::to_string(trial));
      FusionBlock b = start;
      EXPECT_EQ(kernel(b, p, code.data()), n);
      EXPECT_TRUE(SameBits(b.tsdf.data(), expected.tsdf.data(), b.tsdf.size()));
      EXPECT_TRUE(SameBits(b.weight.data(), expected.weight.data(), b.weight.size()));
    }
  }
}

// The band's samples rounded to blocks 8 pixels at a time against the definition
// (BandSampleBlockAt, Eigen's expressions): random poses, depths in front of and behind
// the camera's band, grids that miss some samples, voxel sizes down to the millimetre.
TEST(Fusion, BandSampleKernelsMatchTheDefinition) {
  Rng rng(13);
  const int n = 61;  // not a multiple of 8: a partial last group too
  std::vector<double> xhat(64), d(64);
  for (int trial = 0; trial < 400; ++trial) {
    BandSamples a;
    const Eigen::Quaterniond q(rng.Normal(), rng.Normal(), rng.Normal(), rng.Normal());
    a.R = q.normalized().toRotationMatrix();
    a.t = Vec3(rng.Uniform(-1, 1), rng.Uniform(-1, 1), rng.Uniform(-2, 2));
    a.yv = rng.Uniform(-0.5, 0.5);
    a.h = 1 / rng.Uniform(100, 1000), a.inv_h = 1 / a.h;
    const double mu = (1 + rng.Below(16)) * a.h;
    const int steps = static_cast<int>(std::ceil(2 * mu / (0.5 * kBlockDim * a.h)));
    std::array<double, 64> along;
    for (int k = 0; k <= steps; ++k) along[k] = -mu + 2 * mu * k / steps;
    a.along = along.data(), a.samples = steps + 1;
    for (int i = 0; i < 64; ++i) {
      xhat[i] = rng.Uniform(-0.6, 0.6);
      d[i] = double(float(i % 17 == 0 ? rng.Uniform(0.001, 0.02) : rng.Uniform(0.3, 3.0)));
    }
    a.xhat = xhat.data(), a.d = d.data(), a.n = n;
    const int cells = static_cast<int>(std::ceil(2.0 / (8 * a.h)));
    a.grid_lo = Eigen::Vector3i::Constant(-cells) + Eigen::Vector3i(int(rng.Below(5)), 0, int(rng.Below(5)));
    a.grid_dims = Eigen::Vector3i::Constant(2 * cells - int(rng.Below(cells)));
    auto resolve = [&](int i, int k, int32_t g) -> int64_t {
      if (g != -2) return g;
      Eigen::Vector3i b;
      if (!BandSampleBlockAt(a, i, k, &b)) return -1;
      const Eigen::Vector3i r = b - a.grid_lo;
      if ((r.array() < 0).any() || (r.array() >= a.grid_dims.array()).any()) return -3;  // off the grid
      return (int64_t(r.x()) * a.grid_dims.y() + r.y()) * a.grid_dims.z() + r.z();
    };
    std::vector<int32_t> scalar(64 * size_t(a.samples), 7), fast(64 * size_t(a.samples), 7);
    BandSamplesScalar(a, scalar.data());
    if (HaveAvx512VlBw()) BandSamplesAvx512(a, fast.data());
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < a.samples; ++k) {
        const size_t o = size_t(i / 8) * 8 * a.samples + 8 * size_t(k) + i % 8;
        Eigen::Vector3i b;
        const bool sampled = BandSampleBlockAt(a, i, k, &b);
        ASSERT_EQ(scalar[o] != -1, sampled) << "trial " << trial << " pixel " << i << " sample " << k;
        const int64_t expected = resolve(i, k, scalar[o]);
        if (sampled && scalar[o] != -2) {
          const Eigen::Vector3i r = b - a.grid_lo;
          ASSERT_EQ(scalar[o], (int64_t(r.x()) * a.grid_dims.y() + r.y()) * a.grid_dims.z() + r.z());
        }
        if (HaveAvx512VlBw()) {
          ASSERT_EQ(resolve(i, k, fast[o]), expected) << "trial " << trial << " pixel " << i;
        }
      }
    }
  }
}

// Carving 8 cells at a time against the scalar definition: random poses in front of a
// small camera (cells behind it and off the image too), codes near each cell's depth
// ± μ, no-data and NaN pixels, counts at the settled threshold and at the cap.
TEST(Fusion, CarveRunKernelsMatchTheScalarOne) {
  if (!HaveAvx512VlBw()) GTEST_SKIP() << "no AVX-512VL/BW";
  Rng rng(17);
  const int W = 64, H = 48;
  std::vector<float> code(size_t{W} * H);
  int64_t viewed = 0, freed = 0;  // cells whose counts grew: the test is not vacuous
  for (int trial = 0; trial < 500; ++trial) {
    CarveRun a;
    const Eigen::Quaterniond q(rng.Normal(), rng.Normal(), rng.Normal(), rng.Normal());
    a.Rt = q.normalized().toRotationMatrix();
    a.h = 1 / rng.Uniform(100, 500), a.mu = 4 * a.h;
    a.n = 1 + static_cast<int>(rng.Below(40));
    a.bz0 = static_cast<int>(rng.Below(40)) - 20;
    // The run's middle cell lies 0.1-0.8 m in front of the camera (some cells behind it).
    const int middle = a.bz0 + a.n / 2;  // the run's middle cell
    const Vec3 mid(0, 0, middle * kBlockDim * a.h);
    a.t = mid - a.Rt.transpose() * Vec3(rng.Uniform(-0.2, 0.2), rng.Uniform(-0.2, 0.2), rng.Uniform(-0.05, 0.8));
    a.px = rng.Uniform(-0.05, 0.05), a.py = rng.Uniform(-0.05, 0.05);
    a.fx = a.fy = rng.Uniform(40, 80), a.cx = W / 2.0, a.cy = H / 2.0, a.W = W, a.H = H;
    a.code = code.data();
    for (float& c : code) {
      const uint64_t kind = rng.Below(8);
      const float d = float(rng.Uniform(0.0, 0.9));
      c = kind == 0 ? 0.f : kind == 1 ? std::numeric_limits<float>::quiet_NaN() : kind == 2 ? -d : d;
    }
    std::vector<uint16_t> views(a.n), frees(a.n);
    for (int i = 0; i < a.n; ++i) {
      const uint64_t kind = rng.Below(4);
      views[i] = kind == 0 ? 65535 : kind == 1 ? uint16_t(14 + rng.Below(5)) : uint16_t(rng.Below(40));
      frees[i] = kind == 0 && rng.Below(2) ? 65535 : uint16_t(rng.Below(views[i] + 1));
      if (kind == 1) frees[i] = uint16_t(views[i] / 2 - rng.Below(2));
    }
    std::vector<uint16_t> ev = views, ef = frees;
    for (int frame = 0; frame < 3; ++frame) {  // counts carried over a few views
      CarveRun s = a;
      s.view_count = ev.data(), s.free_count = ef.data();
      CarveRunScalar(s);
      CarveRun f = a;
      f.view_count = views.data(), f.free_count = frees.data();
      const std::vector<uint16_t> views_before = views, frees_before = frees;
      CarveRunAvx512(f);
      for (int i = 0; i < a.n; ++i) viewed += views[i] != views_before[i], freed += frees[i] != frees_before[i];
      ASSERT_EQ(views, ev) << "trial " << trial << " frame " << frame;
      ASSERT_EQ(frees, ef) << "trial " << trial << " frame " << frame;
      a.t += Vec3(rng.Uniform(-0.01, 0.01), 0, rng.Uniform(-0.01, 0.01));
    }
  }
  EXPECT_GT(viewed, 2000);
  EXPECT_GT(freed, 500);
}

// MarkNearForeground's row steps, AVX-512 against scalar: rows of every length up to
// 200 pixels (partial words), random foreground bytes and codes (no data, NaN, depths).
TEST(Fusion, NearForegroundRowKernelsMatchTheScalarOnes) {
  if (!HaveAvx512VlBw()) GTEST_SKIP() << "no AVX-512VL/BW";
  Rng rng(19);
  for (int w = 1; w <= 200; ++w) {
    std::vector<uint8_t> fg(w);
    for (uint8_t& f : fg) f = rng.Below(3) == 0;
    std::vector<uint64_t> scalar((w + 63) / 64, 7), fast((w + 63) / 64, 9);
    PackRowBitsScalar(fg.data(), w, scalar.data());
    PackRowBitsAvx512(fg.data(), w, fast.data());
    ASSERT_EQ(scalar, fast) << "w " << w;
    for (int u = 0; u < w; ++u) ASSERT_EQ((scalar[u / 64] >> (u % 64)) & 1, fg[u]);
    std::vector<float> code(w + 16, 5.f);
    for (int u = 0; u < w; ++u) {
      const uint64_t kind = rng.Below(4);
      code[u] = kind == 0 ? 0.f : kind == 1 ? std::numeric_limits<float>::quiet_NaN() : float(rng.Uniform(-2, 2));
    }
    std::vector<float> expected = code, got = code;
    NanWhereNoDataScalar(scalar.data(), w, expected.data());
    NanWhereNoDataAvx512(scalar.data(), w, got.data());
    ASSERT_TRUE(SameBits(expected.data(), got.data(), code.size())) << "w " << w;
    for (int u = 0; u < w; ++u)
      ASSERT_EQ(std::isnan(expected[u]), std::isnan(code[u]) || (fg[u] && code[u] == 0)) << "w " << w << " u " << u;
  }
}

// The band's voxel rounding by multiplication equals the division's, also on the
// values nearest the voxels' boundaries (x = (i - 0.5)·h and its neighbours).
TEST(Fusion, FloorVoxelEqualsTheDivision) {
  Rng rng(11);
  for (const double vpm : {128.0, 256.0, 384.0, 1000.0, 4096.0}) {
    const double h = 1 / vpm, inv_h = 1 / h;
    for (int k = 0; k < 200000; ++k) {
      double x = rng.Uniform(-3, 3);
      if (k % 2) {
        x = (std::floor(x / h) - 0.5) * h;
        for (int step = static_cast<int>(rng.Below(5)) - 2; step != 0; step += step > 0 ? -1 : 1)
          x = std::nextafter(x, step > 0 ? 10.0 : -10.0);
      }
      ASSERT_EQ(FloorVoxel(x, h, inv_h), FloorInt(x / h + 0.5)) << "x " << x << " h " << h;
    }
  }
}

}  // namespace
}  // namespace drape
