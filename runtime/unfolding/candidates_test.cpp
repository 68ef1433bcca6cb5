#include "runtime/unfolding/candidates.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/error.h"
#include "runtime/registration/test_meshes.h"

namespace drape::unfolding {
namespace {

namespace rec = drape::recognition;
namespace rt = drape::registration::testing;

// A recognition whose ranked entries are (instance, anchor) pairs, best first; `best` is
// entry `best` (the plan prior may have chosen one below the first).
rec::Recognition Entries(const std::vector<std::pair<std::string, std::string>>& e, int best = 0) {
  rec::Recognition r;
  for (size_t i = 0; i < e.size(); ++i) {
    rec::Candidate c;
    c.entry = static_cast<int>(i);
    c.category = "pants";
    c.instance = e[i].first;
    c.anchor = e[i].second;
    c.score = static_cast<double>(i);
    r.entries.push_back(c);
  }
  r.best = r.entries[best];
  r.anchor = r.best.anchor;
  return r;
}

TEST(RegistrationCandidates, RecognitionsAnswerFirstThenItsRankedEntries) {
  const auto r = Entries({{"i0", "left_leg_inner"},
                          {"i1", "left_leg_inner"},
                          {"i0", "right_leg_inner"},
                          {"i1", "left_leg_outer"},
                          {"i0", "crotch"}});
  const auto one = RegistrationCandidates(r, false, "", 1);  // today's loop: the answer alone
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].entry, 0);
  const auto three = RegistrationCandidates(r, false, "", 3);
  ASSERT_EQ(three.size(), 3u);
  EXPECT_EQ(three[1].instance, "i1");                              // the other database instance
  EXPECT_EQ(three[2].anchor, "right_leg_inner");                   // the twin
  EXPECT_EQ(RegistrationCandidates(r, false, "", 10).size(), 5u);  // fewer ranked than k
  EXPECT_THROW(RegistrationCandidates(r, false, "", 0), Error);
}

TEST(RegistrationCandidates, AKeptPlanPriorKeepsItsAnchorOrTwin) {
  // The plan prior took the outer corner ranked fourth: the candidates are that entry,
  // then only entries of the outer corners (either side, any instance).
  const auto r = Entries({{"i0", "left_leg_inner"},
                          {"i1", "right_leg_outer"},
                          {"i0", "right_leg_inner"},
                          {"i0", "left_leg_outer"},
                          {"i1", "left_leg_outer"}},
                         3);
  const auto c = RegistrationCandidates(r, true, "right_leg_outer", 3);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[0].entry, 3);
  EXPECT_EQ(c[1].entry, 1);  // right_leg_outer: its twin
  EXPECT_EQ(c[2].entry, 4);  // the other instance
}

TEST(RegistrationCandidates, AnAimedAnchorRecognitionDidNotRankComesSecond) {
  // The regrasp aimed at a leg's outer corner; recognition (height-gated) answered crotch
  // and did not rank the outer corners among its top anchors: the outer corner's best
  // entry (here its twin's) is registered second, then the ranked entries.
  const auto r = Entries(
      {{"i1", "crotch"}, {"i0", "crotch"}, {"i0", "left_knee"}, {"i0", "left_leg_outer"}, {"i1", "right_leg_outer"}});
  const auto c = RegistrationCandidates(r, false, "right_leg_outer", 4);
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c[0].entry, 0);
  EXPECT_EQ(c[1].entry, 3);
  EXPECT_EQ(c[2].entry, 1);
  EXPECT_EQ(c[3].entry, 2);
  EXPECT_EQ(RegistrationCandidates(r, false, "right_leg_outer", 1).size(), 1u);  // k = 1: the answer alone
}

TEST(KeepCandidate, SmallestUsableFitEarlierOnTies) {
  EXPECT_EQ(KeepCandidate({0.03, 0.01, 0.02}), 1);
  EXPECT_EQ(KeepCandidate({0.02, 0.02}), 0);
  EXPECT_EQ(KeepCandidate({-1, 0.05, std::numeric_limits<double>::quiet_NaN()}), 1);
  EXPECT_EQ(KeepCandidate({-1, -1}), -1);
  EXPECT_EQ(KeepCandidate({}), -1);
}

CandidatePrediction P(const std::string& target, const Vec3& p, double fit, bool usable = true) {
  CandidatePrediction c;
  c.usable = usable, c.target = target, c.point = p, c.fit = fit;
  return c;
}

// Three wrong entries agree on the leg end within 2 cm (one aims at its twin: the same
// physical point); the best-fitting candidate predicts 12 cm away, alone. Its plan is kept,
// the point is the consensus (the agreeing one that fits best).
TEST(ConsensusCandidate, AConsensusOutvotesABetterFittingOutlier) {
  const std::vector<CandidatePrediction> c = {
      P("left_leg_outer", Vec3(0.12, 0.0, 0.0), 0.015), P("left_leg_outer", Vec3(0.0, 0.0, 0.0), 0.024),
      P("right_leg_outer", Vec3(0.01, 0.01, 0.0), 0.022), P("left_leg_outer", Vec3(0.0, 0.015, 0.005), 0.026)};
  std::vector<int> votes;
  EXPECT_EQ(ConsensusCandidate(c, 0, 0.03, &votes), 2);
  EXPECT_EQ(votes, (std::vector<int>{0, 2, 2, 2}));
  EXPECT_EQ(ConsensusCandidate(c, 0, 0.0), 0);    // radius 0: the fit rule, the kept one's point
  EXPECT_EQ(ConsensusCandidate(c, 0, 0.005), 0);  // nobody within 5 mm: ties by fit
}

// Candidates aiming at another target do not vote, however close their points; unusable
// ones neither.
TEST(ConsensusCandidate, OnlyTheKeptTargetOrItsTwinVotes) {
  const std::vector<CandidatePrediction> c = {
      P("left_elbow", Vec3(0.0, 0.0, 0.0), 0.012), P("hem_center", Vec3(0.3, 0.0, 0.0), 0.020),
      P("collar", Vec3(0.3, 0.01, 0.0), 0.021), P("right_elbow", Vec3(0.3, 0.0, 0.01), 0.030, false),
      P("right_elbow", Vec3(0.02, 0.0, 0.0), 0.025)};
  std::vector<int> votes;
  EXPECT_EQ(ConsensusCandidate(c, 0, 0.03, &votes), 0);  // 1 vote each: ties by fit
  EXPECT_EQ(votes, (std::vector<int>{1, -1, -1, -1, 1}));
  EXPECT_EQ(ConsensusCandidate(c, 3, 0.03), -1);  // the kept one must be usable
  EXPECT_EQ(ConsensusCandidate(c, 7, 0.03), -1);
  EXPECT_EQ(ConsensusCandidate({}, 0, 0.03), -1);
}

// Equal votes and equal fits: the earlier (recognition's better rank).
TEST(ConsensusCandidate, TiesByFitThenRank) {
  const std::vector<CandidatePrediction> c = {P("crotch", Vec3(0.0, 0.0, 0.0), 0.02),
                                              P("crotch", Vec3(0.5, 0.0, 0.0), 0.02),
                                              P("crotch", Vec3(0.0, 0.5, 0.0), 0.01)};
  EXPECT_EQ(ConsensusCandidate(c, 0, 0.03), 2);
  const std::vector<CandidatePrediction> same = {P("crotch", Vec3(0.0, 0.0, 0.0), 0.02),
                                                 P("crotch", Vec3(0.5, 0.0, 0.0), 0.02)};
  EXPECT_EQ(ConsensusCandidate(same, 1, 0.03), 0);
}

// The hand-made case: the reconstruction is a hanging tube, slightly deformed;
// recognition ranks a wide, short tube first (another anchor's hang) and the right shape,
// turned by a quarter turn and moved, second. Registered, the right one fits best and is
// kept, after rigid registration and after the non-rigid one.
TEST(KeepCandidate, TheRightShapeRankedSecondFitsBest) {
  const TriMesh tube = rt::FlatTube(24, 18, 0.35, 0.8, 0.06);
  const TriMesh recon{rt::SmoothDeform(tube.V, 0.01, 5.0), tube.F};
  const TriMesh wrong = rt::FlatTube(24, 18, 0.8, 0.35, 0.06);
  TriMesh right = tube;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()).toRotationMatrix();
  for (int i = 0; i < right.NumVertices(); ++i)
    right.V.row(i) = (R * right.V.row(i).transpose() + Vec3(0.05, -0.03, 0.02)).transpose();
  const ExactClosestPoint onto(recon);
  for (const bool nonrigid : {false, true}) {
    const CandidateRegistration a = RegisterCandidate(wrong, recon, onto, nonrigid);
    const CandidateRegistration b = RegisterCandidate(right, recon, onto, nonrigid);
    EXPECT_TRUE(a.note.empty()) << a.note;
    EXPECT_TRUE(b.note.empty()) << b.note;
    EXPECT_LT(b.fit_rigid, 0.01) << "nonrigid " << nonrigid;  // the right shape lands on it
    EXPECT_GT(a.fit_rigid, 2 * b.fit_rigid) << "nonrigid " << nonrigid;
    EXPECT_EQ(KeepCandidate({a.fit_rigid, b.fit_rigid}), 1);
    EXPECT_EQ(KeepCandidate({a.fit_final, b.fit_final}), 1) << "nonrigid " << nonrigid;
    if (!nonrigid) {
      EXPECT_EQ(a.fit_final, a.fit_rigid);
    } else {
      EXPECT_LE(b.fit_final, b.fit_rigid + 1e-9);
    }
  }
}

TEST(LocalFit, MeasuresOnlyTheClothAroundTheCentre) {
  const TriMesh recon = rt::WavySheet(12, 10, 0.5, 0.4, 0.0);  // flat, z = 0, x in [0, 0.5]
  const ExactClosestPoint onto(recon);
  // A registration that fits the left of the sheet exactly and lies 3 cm off on the right.
  TriMesh reg = recon;
  for (int v = 0; v < reg.NumVertices(); ++v)
    if (reg.V(v, 0) > 0.3) reg.V(v, 2) += 0.03;
  // Around the right edge both meshes' patches are the parallel parts: 3 cm both ways.
  EXPECT_NEAR(LocalFit(reg, recon, onto, Vec3(0.5, 0.2, 0.03), 0.1), 0.03, 1e-9);
  // Around the left edge the meshes coincide.
  EXPECT_NEAR(LocalFit(reg, recon, onto, Vec3(0.0, 0.2, 0.0), 0.1), 0.0, 1e-12);
  // The whole garment's fit lies between: what a local difference looks like to it.
  const double whole = SymmetricFit(reg, recon, onto);
  EXPECT_GT(whole, 0.005);
  EXPECT_LT(whole, 0.025);
}

TEST(LocalFit, RegisteredSideAloneWhereTheReconstructionHasNoCloth) {
  const TriMesh recon = rt::WavySheet(12, 10, 0.5, 0.4, 0.0);
  const ExactClosestPoint onto(recon);
  TriMesh reg = recon;
  reg.V.col(0).array() += 1.0;  // x in [1, 1.5]: nowhere near the reconstruction
  // No reconstructed patch within 10 cm of the centre: the registered patches' distance
  // to the reconstruction (x >= 0.9 m away) alone.
  const double f = LocalFit(reg, recon, onto, Vec3(1.5, 0.2, 0.0), 0.1);
  EXPECT_GT(f, 0.9);
  EXPECT_LT(f, 1.0);
  // Neither mesh has a patch there.
  EXPECT_EQ(LocalFit(reg, recon, onto, Vec3(5, 5, 5), 0.1), -1.0);
}

TEST(LowestPoint, TheHangsLowestVertexAndTheReconstructionsLiftedAboveIt) {
  // A sheet hanging in the x-y plane (y up), tilted so that its corner (0.5, 0) is lowest.
  TriMesh hang = rt::WavySheet(11, 9, 0.5, 0.4, 0.0);
  for (int v = 0; v < hang.NumVertices(); ++v) hang.V(v, 1) -= 0.2 * hang.V(v, 0);  // right side lower
  const int corner = 10;                                                            // i = 10, j = 0: (0.5, -0.1)
  const int left = 0;                                                               // (0, 0)
  EXPECT_TRUE(AnchorIsLowest(hang, corner, 0.0));
  EXPECT_FALSE(AnchorIsLowest(hang, left, 0.05));  // 10 cm above the lowest
  EXPECT_TRUE(AnchorIsLowest(hang, left, 0.1 + 1e-9));
  EXPECT_THROW(AnchorIsLowest(hang, -1, 0.03), Error);
  EXPECT_THROW(AnchorIsLowest(hang, hang.NumVertices(), 0.03), Error);

  LowestPointOptions o;  // 2 cm lift, 2 cm floor margin
  const auto p = LowestPoint(hang, -1.0, o);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR((*p - Vec3(0.5, -0.1 + 0.02, 0.0)).norm(), 0.0, 1e-12);
  // A lowest point at the region's floor is where the fusion cut the garment: none.
  EXPECT_FALSE(LowestPoint(hang, -0.11, o).has_value());
  EXPECT_TRUE(LowestPoint(hang, -0.13, o).has_value());
  EXPECT_FALSE(LowestPoint(TriMesh{}, -1.0, o).has_value());
}

TEST(LowestPoint, NearTheTargetTheLowestWithinTheRadiusNotTheGarments) {
  // A leg hanging beside a lower waist (x-y plane, y up): the leg's hem corner at
  // (0, -0.30), 2 cm above its hem's other points; the waist 12 cm away down to y = -0.42.
  TriMesh hang;
  hang.V.resize(5, 3);
  hang.V << 0.0, -0.30, 0.0,                          // 0: the leg's hem corner (the target)
      0.04, -0.28, 0.0,                               // 1: its hem, 4 cm in
      0.0, -0.10, 0.0,                                // 2: the leg above it
      0.12, -0.42, 0.0,                               // 3: the waist, the hang's lowest
      0.30, -0.35, 0.0;                               // 4
  EXPECT_FALSE(AnchorIsLowest(hang, 0, 0.03));        // 12 cm above the hang's lowest
  EXPECT_TRUE(AnchorIsLowest(hang, 0, 0.03, 0.06));   // the lowest within 6 cm
  EXPECT_FALSE(AnchorIsLowest(hang, 2, 0.03, 0.06));  // the corner lies below it
  EXPECT_TRUE(AnchorIsLowest(hang, 1, 0.03, 0.06));   // 2 cm above the corner, within the tolerance
  EXPECT_FALSE(AnchorIsLowest(hang, 1, 0.01, 0.06));
  EXPECT_FALSE(AnchorIsLowest(hang, 0, 0.03, 0.2));  // a radius that reaches the waist
  // The reconstruction, the registration 4 cm off the corner: the corner, lifted 2 cm.
  LowestPointOptions o;  // near_radius 6 cm
  const auto p = LowestPoint(hang, -1.0, o, Vec3(-0.04, -0.27, 0.0));
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR((*p - Vec3(0.0, -0.28, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((*LowestPoint(hang, -1.0, o) - Vec3(0.12, -0.40, 0.0)).norm(), 0.0, 1e-12);  // without: the waist
  // Nothing within the radius, or the corner at the region's floor: none.
  EXPECT_FALSE(LowestPoint(hang, -1.0, o, Vec3(1.0, -0.3, 1.0)).has_value());
  EXPECT_FALSE(LowestPoint(hang, -0.31, o, Vec3(0.0, -0.3, 0.0)).has_value());
}

TEST(LowestPoint, OptionsAreChecked) {
  LowestPointOptions o;
  EXPECT_NO_THROW(o.Validate());
  o.near_radius = -0.01;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.lift = -0.01;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.tolerance = std::nan("");
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.floor_margin = 0.6;
  EXPECT_THROW(o.Validate(), Error);
}

TEST(HangingEnd, AnElbowsEndIsItsCuff) {
  EXPECT_EQ(HangingEnd("left_elbow"), "left_cuff");
  EXPECT_EQ(HangingEnd("right_elbow"), "right_cuff");
  EXPECT_EQ(HangingEnd("left_leg_outer"), "");  // a leg end is the lowest point itself
  EXPECT_EQ(HangingEnd(""), "");
}

TEST(HangingEnd, TheLowestVertexNearTheRegisteredEndNotTheWholeGarmentsLowest) {
  // Two hanging strips in the x-y plane (y up): a sleeve at x = 0 whose end is at y = -0.6,
  // and a body at x = 0.3 hanging lower, to y = -0.9.
  TriMesh recon;
  recon.V.resize(4, 3);
  recon.V << 0.0, -0.3, 0.0,  //
      0.0, -0.6, 0.01,        // the sleeve's end
      0.3, -0.5, 0.0,         //
      0.3, -0.9, 0.0;         // the body's hem: the garment's lowest point
  HangingEndOptions o;        // 10 cm radius
  // The registration puts the end 6 cm beside the sleeve and 5 cm too low: the sleeve's end.
  const auto p = LowestNear(recon, Vec3(0.06, -0.65, 0.0), -2.0, o);
  ASSERT_TRUE(p.has_value());
  EXPECT_NEAR((*p - Vec3(0.0, -0.6, 0.01)).norm(), 0.0, 1e-12);
  // A radius that reaches the body takes its hem.
  o.radius = 0.3;
  EXPECT_NEAR((*LowestNear(recon, Vec3(0.06, -0.65, 0.0), -2.0, o) - Vec3(0.3, -0.9, 0.0)).norm(), 0.0, 1e-12);
  o = {};
  // Nothing within the radius, or the end at the region's floor (the fusion's cut): none.
  EXPECT_FALSE(LowestNear(recon, Vec3(0.5, -0.6, 0.5), -2.0, o).has_value());
  EXPECT_FALSE(LowestNear(recon, Vec3(0.0, -0.6, 0.0), -0.61, o).has_value());
  EXPECT_TRUE(LowestNear(recon, Vec3(0.0, -0.6, 0.0), -0.63, o).has_value());
  EXPECT_FALSE(LowestNear(TriMesh{}, Vec3::Zero(), -2.0, o).has_value());
}

TEST(HangingEnd, OptionsAreChecked) {
  HangingEndOptions o;
  EXPECT_NO_THROW(o.Validate());
  o.radius = 0;
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.floor_margin = std::nan("");
  EXPECT_THROW(o.Validate(), Error);
  o = {};
  o.min_drop = 1.5;
  EXPECT_THROW(o.Validate(), Error);
}

}  // namespace
}  // namespace drape::unfolding

namespace drape::unfolding {
namespace {

// A horizontal square (side 1 m) at height y, centred on the turning axis.
TriMesh Square(double y) {
  TriMesh m;
  m.V.resize(4, 3);
  m.V << -0.5, y, -0.5, 0.5, y, -0.5, 0.5, y, 0.5, -0.5, y, 0.5;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 2, 3;
  return m;
}

TEST(OutsideRegion, BoxDistanceOrRadialExcessWhicheverIsLarger) {
  const Eigen::AlignedBox3d box(Vec3(-0.6, -1.45, -0.6), Vec3(0.6, -0.02, 0.6));
  EXPECT_DOUBLE_EQ(OutsideRegion(Vec3(0.1, -1.0, 0.2), box, 0.55), 0);
  EXPECT_NEAR(OutsideRegion(Vec3(0.1, -1.55, 0.2), box, 0.55), 0.10, 1e-12);  // below the floor face
  EXPECT_NEAR(OutsideRegion(Vec3(0.0, -0.01, 0.0), box, 0.55), 0.01, 1e-12);  // above the top face
  // Radial: 0.58 m from the axis is 3 cm past the cylinder but inside the box.
  EXPECT_NEAR(OutsideRegion(Vec3(0.58, -1.0, 0.0), box, 0.55), 0.03, 1e-12);
  EXPECT_DOUBLE_EQ(OutsideRegion(Vec3(0.58, -1.0, 0.0), box, 0), 0);  // no radial limit
  // Corner below and outside: the box's exterior distance (Euclidean to the corner).
  EXPECT_NEAR(OutsideRegion(Vec3(0.63, -1.49, 0.0), box, 0), 0.05, 1e-12);
}

TEST(PredictAnchor, MappedOntoTheReconstructionUnlessOutsideTheRegion) {
  const Eigen::AlignedBox3d box(Vec3(-0.6, -1.45, -0.6), Vec3(0.6, -0.02, 0.6));
  // The reconstruction is cut at the region's floor: its lowest surface at y = -1.46.
  const TriMesh recon = Square(-1.46);
  const ExactClosestPoint onto(recon);
  // Inside the region: the registered point (not the rigid one) mapped onto the surface.
  AnchorPrediction p = PredictAnchor(Vec3(0.1, -1.40, 0.1), Vec3(0.2, -1.30, 0.1), onto, box, 0.55, 0.02);
  EXPECT_FALSE(p.unobserved);
  EXPECT_NEAR((p.point - Vec3(0.2, -1.46, 0.1)).norm(), 0, 1e-12);
  // 1.5 cm below the floor face: within the margin, still mapped.
  p = PredictAnchor(Vec3(0.1, -1.465, 0.1), Vec3(0.2, -1.30, 0.1), onto, box, 0.55, 0.02);
  EXPECT_FALSE(p.unobserved);
  // 12 cm below it: the reconstruction has nothing there; the rigid point as it is.
  p = PredictAnchor(Vec3(0.1, -1.57, 0.1), Vec3(0.2, -1.46, 0.1), onto, box, 0.55, 0.02);
  EXPECT_TRUE(p.unobserved);
  EXPECT_NEAR((p.point - Vec3(0.1, -1.57, 0.1)).norm(), 0, 1e-12);
  // A negative margin maps every anchor (the paper's rule).
  p = PredictAnchor(Vec3(0.1, -1.57, 0.1), Vec3(0.2, -1.50, 0.1), onto, box, 0.55, -1);
  EXPECT_FALSE(p.unobserved);
  EXPECT_NEAR((p.point - Vec3(0.2, -1.46, 0.1)).norm(), 0, 1e-12);
}

// The kept candidate 8 cm from three others that agree within 2 cm (one aims at the twin):
// their medoid. Near them, or with fewer than two others aiming at its target, the kept one.
TEST(OutlierCandidate, TheOthersMedoidReplacesAFarKeptPoint) {
  std::vector<CandidatePrediction> c = {
      P("left_leg_outer", Vec3(0.08, 0.0, 0.0), 0.015), P("left_leg_outer", Vec3(0.0, 0.02, 0.0), 0.024),
      P("right_leg_outer", Vec3(0.0, 0.0, 0.0), 0.022), P("left_leg_outer", Vec3(0.0, -0.02, 0.0), 0.026),
      P("crotch", Vec3(0.08, 0.0, 0.0), 0.020)};
  EXPECT_EQ(OutlierCandidate(c, 0, 0.04), 2);   // the middle one: least summed distance
  EXPECT_EQ(OutlierCandidate(c, 0, 0.085), 0);  // within the radius: kept
  EXPECT_EQ(OutlierCandidate(c, 0, 0.0), 0);    // off
  c[0].point = Vec3(0.03, 0.0, 0.0);
  EXPECT_EQ(OutlierCandidate(c, 0, 0.04), 0);
  // Only one other aims at the target (the crotch's plan does not count, nor an unusable one).
  c[0].point = Vec3(0.08, 0.0, 0.0);
  c[1].usable = false;
  c[3].target = "crotch";
  EXPECT_EQ(OutlierCandidate(c, 0, 0.04), 0);
  EXPECT_EQ(OutlierCandidate(c, 1, 0.04), -1);  // the kept one must be usable
  EXPECT_EQ(OutlierCandidate({}, 0, 0.04), -1);
}

}  // namespace
}  // namespace drape::unfolding
