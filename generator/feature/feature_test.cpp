#include "generator/feature/feature.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/rng.h"
#include "generator/fusion/fusion.h"
#include "generator/fusion/synthetic.h"

namespace drape {
namespace {

using synthetic::Scene;
using synthetic::Shape;

// An asymmetric garment-like shape hanging below the grasp point: a torso box offset
// from the axis, one tilted sleeve, a hood-like sphere.
Scene Garment() {
  Scene s;
  s.shapes.push_back(Shape::Box(Vec3(0.04, -0.35, 0.01), Vec3(0.2, 0.3, 0.05),
                                Eigen::AngleAxisd(0.3, Vec3::UnitY()).toRotationMatrix()));
  s.shapes.push_back(
      Shape::Cylinder(Vec3(0.28, -0.25, 0.05), 0.05, 0.18, Eigen::AngleAxisd(0.6, Vec3::UnitZ()).toRotationMatrix()));
  s.shapes.push_back(Shape::Sphere(Vec3(-0.05, -0.08, -0.04), 0.07));
  return s;
}

// Points within 1 mm of the surface, found by rejection (deterministic).
Points3 SurfacePoints(const std::function<double(const Vec3&)>& sdf, uint64_t seed) {
  Rng rng(seed);
  std::vector<Vec3> pts;
  while (pts.size() < 4000) {
    const double px = rng.Uniform(-0.5, 0.5), py = rng.Uniform(-0.75, 0.05), pz = rng.Uniform(-0.5, 0.5);
    const Vec3 p(px, py, pz);
    if (std::abs(sdf(p)) < 0.003) pts.push_back(p);
  }
  Points3 P(pts.size(), 3);
  for (size_t i = 0; i < pts.size(); ++i) P.row(i) = pts[i];
  return P;
}

Feature RandomFeature(int n, int r, int phi, Rng& rng) {
  Feature f;
  f.layers = n;
  f.rings = r;
  f.sectors = phi;
  f.words.assign((f.NumBits() + 63) / 64, 0);
  for (int l = 0; l < n; ++l)
    for (int i = 0; i < r; ++i)
      for (int s = 0; s < phi; ++s) f.Set(l, i, s, rng.Uniform() < 0.4);
  return f;
}

TEST(Feature, BitOrderAndPacking) {
  Feature f;
  f.layers = 2;
  f.rings = 3;
  f.sectors = 12;
  f.words.assign(2, 0);
  f.Set(1, 2, 5, true);  // (1·3 + 2)·12 + 5 = 65
  EXPECT_EQ(f.words[0], 0u);
  EXPECT_EQ(f.words[1], 2u);
  EXPECT_TRUE(f.Get(1, 2, 5));
  EXPECT_EQ(f.PopCount(), 1);
  // Rotating by k moves sector s to s + k (mod Φ), per ring.
  const Feature g = Rotate(f, 9);
  EXPECT_TRUE(g.Get(1, 2, 2));
  EXPECT_EQ(g.PopCount(), 1);
  EXPECT_EQ(Rotate(f, -3), g);
  EXPECT_EQ(Rotate(g, 3), f);
}

// Four points, two of them in the top layer (x = 0.1 and `second_top_x`), and a 4×2×4 shape.
Points3 FourPoints(double second_top_x) {
  Points3 P(4, 3);
  P << 0.1, 0.0, 0.0,            //
      second_top_x, -0.01, 0.0,  //
      0.3, -1.0, 0.0,            //
      0.0, -0.5, -0.2;
  return P;
}
FeatureOptions SmallShape() {
  FeatureOptions o;
  o.layers = 4;
  o.rings = 2;
  o.sectors = 4;
  return o;
}

TEST(Feature, CellGeometryFollowsAlgorithm1) {
  const Points3 P = FourPoints(-0.1);
  const FeatureOptions o = SmallShape();
  const FeatureFrame fr = ComputeFeatureFrame(P, o);
  EXPECT_DOUBLE_EQ(fr.y_max, 0.0);
  EXPECT_DOUBLE_EQ(fr.layer_height, 0.25);
  EXPECT_NEAR(fr.origin_x, 0.0, 1e-15);  // mean of the top layer's two points
  EXPECT_NEAR(fr.r_max, 0.3, 1e-15);
  // Layer 1, ring 1, sector 1: y = -0.375, radius 0.225, angle 3π/4 → (−, ·, −).
  const Vec3 c = CellCentre(fr, o, 1, 1, 1);
  EXPECT_NEAR(c.y(), -0.375, 1e-12);
  EXPECT_NEAR(c.x(), 0.225 * std::cos(0.75 * M_PI), 1e-12);
  EXPECT_NEAR(c.z(), -0.225 * std::sin(0.75 * M_PI), 1e-12);
  // A solid cylinder of radius 0.3·(1/2) fills ring 0 only.
  const Feature f = ExtractFeature(
      P, [](const Vec3& p) { return std::hypot(p.x(), p.z()) - 0.15; }, o);
  for (int l = 0; l < 4; ++l)
    for (int s = 0; s < 4; ++s) {
      EXPECT_TRUE(f.Get(l, 0, s));
      EXPECT_FALSE(f.Get(l, 1, s));
    }
}

// origin "grip": the polar axis is the gripper's (x = z = 0), not the top layer's mean.
TEST(Feature, GripOriginIsTheGrippersAxis) {
  const Points3 P = FourPoints(0.3);
  FeatureOptions o = SmallShape();
  const FeatureFrame top = ComputeFeatureFrame(P, o);
  EXPECT_NEAR(top.origin_x, 0.2, 1e-15);  // the top layer's mean
  EXPECT_NEAR(top.r_max, std::hypot(0.2, 0.2), 1e-15);
  o.origin = "grip";
  const FeatureFrame grip = ComputeFeatureFrame(P, o);
  EXPECT_EQ(grip.origin_x, 0.0);
  EXPECT_EQ(grip.origin_z, 0.0);
  EXPECT_NEAR(grip.r_max, 0.3, 1e-15);
  EXPECT_EQ(grip.y_max, top.y_max);
  EXPECT_EQ(grip.layer_height, top.layer_height);
  // A cylinder about the gripper's axis fills ring 0 only, whichever way the top layer leans.
  const Feature f = ExtractFeature(
      P, [](const Vec3& p) { return std::hypot(p.x(), p.z()) - 0.15; }, o);
  for (int l = 0; l < 4; ++l)
    for (int s = 0; s < 4; ++s) {
      EXPECT_TRUE(f.Get(l, 0, s));
      EXPECT_FALSE(f.Get(l, 1, s));
    }
}

TEST(Feature, RotatedGarmentMatchesAtItsRotation) {
  const Scene garment = Garment();
  for (int phi : {8, 12, 16}) {
    FeatureOptions o;
    o.sectors = phi;
    o.origin = phi == 12 ? "grip" : "top_layer";  // both axes turn with the garment
    const auto sdf0 = [&](const Vec3& p) { return garment.Sdf(p); };
    const Points3 P0 = SurfacePoints(sdf0, 1);
    const Feature f0 = ExtractFeature(P0, sdf0, o);
    EXPECT_GT(f0.PopCount(), 50);
    for (int k = 1; k < phi; k += 3) {
      const Eigen::Matrix3d Rk = Eigen::AngleAxisd(2 * M_PI * k / phi, Vec3::UnitY()).toRotationMatrix();
      const auto sdfk = [&](const Vec3& p) { return garment.Sdf(Rk.transpose() * p); };
      const Points3 Pk = (P0 * Rk.transpose()).eval();
      const Feature fk = ExtractFeature(Pk, sdfk, o);
      const Match m = Distance(f0, fk);
      // Exact up to floating-point ties at cell centres: allow 2 bits.
      EXPECT_LE(m.distance, 2) << "phi " << phi << " k " << k;
      EXPECT_EQ(m.rotation, k) << "phi " << phi;
      EXPECT_LE(Distance(Rotate(f0, k), fk).distance, 2);
      // Without the rotation search the features differ a lot.
      int plain = 0;
      for (size_t w = 0; w < f0.words.size(); ++w) plain += __builtin_popcountll(f0.words[w] ^ fk.words[w]);
      EXPECT_GT(plain, 20);
    }
  }
}

// Mirror: the feature of the mirrored garment (z → −z, any mirror plane through the axis
// up to a turn), sector s ↔ Φ − 1 − s; an involution; a chiral shape's mirror is not
// one of its rotations.
TEST(Feature, MirroredGarmentIsTheMirroredCode) {
  const Scene garment = Garment();
  for (const char* origin : {"top_layer", "grip"}) {
    FeatureOptions o;
    o.origin = origin;
    const auto sdf0 = [&](const Vec3& p) { return garment.Sdf(p); };
    const Points3 P0 = SurfacePoints(sdf0, 1);
    const Feature f0 = ExtractFeature(P0, sdf0, o);
    EXPECT_EQ(Mirror(Mirror(f0)), f0);
    // Mirror through the z = 0 plane turned by `plane` about y: the z = 0 mirror and a turn
    // by 2·plane, here 3 sectors (the feature is rotation-invariant in sector steps).
    for (double plane : {0.0, 3 * M_PI / 16}) {
      const Eigen::Matrix3d R = Eigen::AngleAxisd(plane, Vec3::UnitY()).toRotationMatrix();
      const Eigen::Matrix3d M = R * Vec3(1, 1, -1).asDiagonal() * R.transpose();
      const auto sdfm = [&](const Vec3& p) { return garment.Sdf(M * p); };
      const Feature fm = ExtractFeature((P0 * M.transpose()).eval(), sdfm, o);
      const Match m = Distance(Mirror(f0), fm);
      EXPECT_LE(m.distance, 2) << origin << " plane " << plane;  // floating-point ties at cell centres
      if (plane == 0.0) {
        EXPECT_EQ(m.rotation, 0);
      }
      EXPECT_GT(Distance(f0, fm).distance, 20) << origin;  // the garment is chiral: no turn makes its mirror
    }
  }
}

// The same with SDFs fused from synthetic depth sweeps: the voxel grid does not turn
// with the garment, so the match is close but not exact.
TEST(Feature, FusedGarmentRotatedMatchesWithinAFewBits) {
  const Scene garment = Garment();
  const Intrinsics K = synthetic::SmallCamera();
  synthetic::TurntableOptions t;
  t.frames = 40;
  FeatureOptions o;
  const int k = 5;
  const Eigen::Matrix3d Rk = Eigen::AngleAxisd(2 * M_PI * k / o.sectors, Vec3::UnitY()).toRotationMatrix();
  Scene turned;
  for (Shape s : garment.shapes) {
    s.center = Rk * s.center;
    s.rotation = Rk * s.rotation;
    turned.shapes.push_back(s);
  }
  FusionOptions fo;
  fo.frames_stride = 1;
  const FusionResult a = FuseFrames(synthetic::RenderTurntable(garment, K, t), K, fo, 1);
  const FusionResult b = FuseFrames(synthetic::RenderTurntable(turned, K, t), K, fo, 1);
  const Feature fa = ExtractFeature(
      a.mesh.V, [&](const Vec3& p) { return a.tsdf->Sdf(p); }, o);
  const Feature fb = ExtractFeature(
      b.mesh.V, [&](const Vec3& p) { return b.tsdf->Sdf(p); }, o);
  const Match m = Distance(fa, fb);
  std::printf("fused garment turned by 5/16: distance %d of %d bits (%d set), rotation %d\n", m.distance, fa.NumBits(),
              fa.PopCount(), m.rotation);
  EXPECT_EQ(m.rotation, k);
  EXPECT_LE(m.distance, 0.08 * fa.PopCount());  // measured 22 bits of 523 set
}

TEST(Feature, FastDistanceEqualsReference) {
  Rng rng(42);
  const int shapes[][3] = {{16, 16, 16}, {16, 16, 8}, {16, 16, 12}, {16, 16, 20}, {3, 5, 7},
                           {1, 1, 1},    {2, 3, 64},  {5, 3, 32},   {7, 9, 13},   {4, 4, 2}};
  for (const auto& sh : shapes) {
    for (int trial = 0; trial < 6; ++trial) {
      const Feature a = RandomFeature(sh[0], sh[1], sh[2], rng);
      Feature b = RandomFeature(sh[0], sh[1], sh[2], rng);
      if (trial % 2 == 0) {
        // Mostly a rotated copy with a few flipped bits, so the minimum is sharp.
        b = Rotate(a, int(rng.Below(sh[2])));
        for (int i = 0; i < 5; ++i) {
          const int l = int(rng.Below(sh[0])), r = int(rng.Below(sh[1])), s = int(rng.Below(sh[2]));
          b.Set(l, r, s, rng.Uniform() < 0.5);
        }
      }
      const Match fast = Distance(a, b), ref = DistanceReference(a, b);
      ASSERT_EQ(fast.distance, ref.distance) << sh[0] << "x" << sh[1] << "x" << sh[2];
      ASSERT_EQ(fast.rotation, ref.rotation) << sh[0] << "x" << sh[1] << "x" << sh[2];
      for (int k = 0; k < sh[2]; ++k) {
        // Rotate agrees with the reference's bit mapping.
        const Feature r = Rotate(a, k);
        for (int l = 0; l < sh[0]; ++l)
          for (int i = 0; i < sh[1]; ++i)
            for (int s = 0; s < sh[2]; ++s) ASSERT_EQ(r.Get(l, i, (s + k) % sh[2]), a.Get(l, i, s));
      }
    }
  }
  const Feature a = RandomFeature(2, 2, 8, rng), b = RandomFeature(2, 2, 16, rng);
  EXPECT_THROW(Distance(a, b), Error);
}

TEST(Feature, EncodeDecodeRoundTripAndErrors) {
  Rng rng(9);
  for (const auto& sh : {std::array<int, 3>{16, 16, 16}, std::array<int, 3>{3, 5, 7}}) {
    const Feature f = RandomFeature(sh[0], sh[1], sh[2], rng);
    const std::string bytes = EncodeFeature(f);
    EXPECT_EQ(bytes.size(), 24 + 8 * f.words.size());
    EXPECT_EQ(DecodeFeature(bytes, "x"), f);
  }
  const Feature f = RandomFeature(3, 5, 7, rng);
  const std::string good = EncodeFeature(f);
  auto expect_error = [](const std::string& bytes, const std::string& needle) {
    try {
      DecodeFeature(bytes, "entries/e1/feature.bin");
      ADD_FAILURE() << "no error for " << needle;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind("entries/e1/feature.bin", 0), 0u) << what;
      EXPECT_NE(what.find(needle), std::string::npos) << what;
    }
  };
  expect_error(good.substr(0, 10), "truncated");
  expect_error(good.substr(0, good.size() - 1), "size");
  expect_error(good + "x", "size");
  std::string b = good;
  b[0] = 'X';
  expect_error(b, "magic");
  b = good;
  b[4] = 2;
  expect_error(b, "version");
  b = good;
  b[16] = 0;  // Φ = 0
  expect_error(b, "shape");
  b = good;
  b[20] = 7;  // word count
  expect_error(b, "word count");
  b = good;
  b[b.size() - 1] = char(0x80);  // bit 127 of 105 used
  expect_error(b, "padding");
}

TEST(Feature, BadInputIsRejected) {
  FeatureOptions o;
  o.sectors = 65;
  EXPECT_THROW(o.Validate(), Error);
  o = FeatureOptions();
  o.origin = "centre";
  EXPECT_THROW(o.Validate(), Error);
  o = FeatureOptions();
  const auto sdf = [](const Vec3&) { return -1.0; };
  EXPECT_THROW(ExtractFeature(Points3(0, 3), sdf, o), Error);
  Points3 flat(2, 3);
  flat << 0, -1, 0, 1, -1, 0;
  EXPECT_THROW(ExtractFeature(flat, sdf, o), Error);
}

}  // namespace
}  // namespace drape
