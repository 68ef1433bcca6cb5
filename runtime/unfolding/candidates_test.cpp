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
