#include "runtime/unfolding/loop.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/error.h"
#include "common/field_error.h"
#include "runtime/unfolding/report.h"

namespace drape::unfolding {
namespace {

// A recognition whose ranked anchors are `anchors`, best first.
recognition::Recognition Ranked(const std::vector<std::string>& anchors) {
  recognition::Recognition r;
  for (size_t i = 0; i < anchors.size(); ++i) {
    recognition::Candidate c;
    c.entry = static_cast<int>(i);
    c.anchor = anchors[i];
    r.top.push_back(c);
  }
  r.anchor = anchors.front();
  r.best = r.top.front();
  return r;
}

TEST(LoopOptions, ALeftOutCategorysPenaltyIsNotNegative) {
  LoopOptions o;
  EXPECT_EQ(o.recognise.refit_absent_penalty, 0.5);
  o.recognise.refit_absent_penalty = 0;
  EXPECT_NO_THROW(o.Validate());
  o.recognise.refit_absent_penalty = -0.1;
  EXPECT_THROW(o.Validate(), Error);
}

// Each phase's options are checked; the error names the struct and field and carries the
// field's address (what an options file maps back to the key that set it).
TEST(LoopOptions, EachPhaseNamesItsBadField) {
  auto bad = [](const LoopOptions& o, const void* field, const std::string& name) {
    try {
      o.Validate();
    } catch (const FieldError& e) {
      EXPECT_EQ(e.field(), field) << e.what();
      EXPECT_EQ(e.name(), name) << e.what();
      return;
    }
    ADD_FAILURE() << name << ": no FieldError";
  };
  EXPECT_NO_THROW(LoopOptions{}.Validate());
  LoopOptions o;
  o.observe.sensing_height = 0.2;
  bad(o, &o.observe.sensing_height, "ObserveOptions.sensing_height");
  o = {};
  o.observe.capture.frames = 0;
  bad(o, &o.observe.capture.frames, "CaptureOptions.frames");
  o = {};
  o.recognise.plan_prior_top_k = 6;
  bad(o, &o.recognise.plan_prior_top_k, "RecogniseOptions.plan_prior_top_k");
  o = {};
  o.plan.candidates = 0;
  bad(o, &o.plan.candidates, "PlanOptions.candidates");
  o = {};
  o.plan.lowest.near_radius = 0.5;
  bad(o, &o.plan.lowest.near_radius, "LowestPointOptions.near_radius");
  o = {};
  o.plan.objective.xi = 0;
  bad(o, &o.plan.objective.xi, "ObjectiveOptions.xi");
  o = {};
  o.regrasp.standoff = 0.5;
  bad(o, &o.regrasp.standoff, "RegraspOptions.standoff");
  o = {};
  o.max_regrasps = 0;
  bad(o, &o.max_regrasps, "LoopOptions.max_regrasps");
  o = {};
  o.place.spread = 2;
  bad(o, &o.place.spread, "PlaceFlatOptions.spread");
}

TEST(PlanPrior, KeepsTheAimedAnchorOrItsTwinWithinTheTopK) {
  // The trouser-leg case of the paper release: a hang from a leg's outer corner is ranked
  // behind both inner corners.
  const auto r = Ranked({"left_leg_inner", "right_leg_inner", "right_leg_outer", "crotch"});
  EXPECT_EQ(PlanPriorRank(r, "right_leg_outer", 3), 2);
  EXPECT_EQ(PlanPriorRank(r, "left_leg_outer", 3), 2);  // its twin
  EXPECT_EQ(PlanPriorRank(r, "left_leg_inner", 3), 0);
  EXPECT_EQ(PlanPriorRank(r, "right_leg_outer", 2), -1);  // beyond k: recognition's answer
  EXPECT_EQ(PlanPriorRank(r, "crotch", 3), -1);
  EXPECT_EQ(PlanPriorRank(r, "crotch", 5), 3);
  EXPECT_EQ(PlanPriorRank(r, "waist_center", 5), -1);            // not ranked at all
  EXPECT_EQ(PlanPriorRank(r, "left_leg_inner", 0), -1);          // off: the paper's afresh
  EXPECT_EQ(PlanPriorRank(r, "", 3), -1);                        // first step: nothing aimed
  EXPECT_EQ(PlanPriorRank(Ranked({"collar"}), "collar", 3), 0);  // fewer ranked than k
}

TEST(PlanPrior, TrustedAimedEntryIsTheBestEntryOfTheAimedAnchorOrItsTwin) {
  // The held leg end's entries ranked behind the crotch and the knees (a hang after a
  // let-go that the database never shows): trusting the arm takes the best of them.
  recognition::Recognition r = Ranked({"crotch"});
  for (const std::string a : {"crotch", "left_knee", "right_leg_outer", "left_leg_outer", "right_leg_outer"}) {
    recognition::Candidate c;
    c.entry = static_cast<int>(r.entries.size());
    c.anchor = a;
    r.entries.push_back(c);
  }
  EXPECT_EQ(PlanPriorRank(r, "left_leg_outer", 5), -1);  // beyond recognition's top anchors
  EXPECT_EQ(TrustedAimedEntry(r, "left_leg_outer"), 2);  // its twin's entry ranks first
  EXPECT_EQ(TrustedAimedEntry(r, "right_leg_outer"), 2);
  EXPECT_EQ(TrustedAimedEntry(r, "left_knee"), 1);
  EXPECT_EQ(TrustedAimedEntry(r, "waist_center"), -1);             // no entry of it
  EXPECT_EQ(TrustedAimedEntry(r, ""), -1);                         // first step: nothing aimed
  EXPECT_EQ(TrustedAimedEntry(Ranked({"crotch"}), "crotch"), -1);  // no entries listed
}

TEST(Stop, AtXiOnlyOnARegraspedHolder) {
  const ObjectiveOptions o;              // ξ = 0.5
  EXPECT_FALSE(MayStop(o, 1.0, false));  // the random first grasp, recognised as a leg end
  EXPECT_TRUE(MayStop(o, 1.0, true));
  EXPECT_TRUE(MayStop(o, 0.5, true));
  EXPECT_FALSE(MayStop(o, 0.19, true));  // a leg's inner corner and the other leg end
}

TEST(Stop, DeclaresOnlyWhatItsOwnHangSupports) {
  Recognised r;
  r.category = "shorts";
  r.recognition.anchor = "right_leg_outer";
  r.recognised_anchor = "right_leg_outer";
  EXPECT_EQ(UnsupportedBelief(r, 3), "");  // recognition's own answer, no category fit (category known)
  r.category_fit = {{"category", "shorts"}};
  EXPECT_EQ(UnsupportedBelief(r, 3), "");
  r.category_fit = {{"category", ""}};  // nothing registered at this hang: nothing against the belief
  EXPECT_EQ(UnsupportedBelief(r, 3), "");
  r.category_fit = {{"category", "long_sleeve_shirt"}};
  EXPECT_EQ(UnsupportedBelief(r, 3),
            "its own hang fits long_sleeve_shirt best by registration, the plan stands on shorts");
  r.category_fit = {{"category", "shorts"}};
  r.recognised_anchor = "waist_center";  // the aimed anchor kept beyond the top 3
  r.prior_trusted = true;
  EXPECT_EQ(UnsupportedBelief(r, 3),
            "its own hang does not rank the held anchor right_leg_outer (or a twin) in its top 3 (recognition: "
            "waist_center)");
}

TEST(Report, CountsWhatDecidingOnTheBeliefAloneWouldHaveDeclared) {
  std::vector<TrialResult> trials(3);
  trials[0].belief_step = 1, trials[0].belief_regrasps = 2, trials[0].belief_unfolded = true;  // verified there
  trials[0].converged = trials[0].unfolded = true, trials[0].regrasps = 2;
  trials[1].belief_step = 1, trials[1].belief_regrasps = 2, trials[1].rejected = 1;  // held back, unfolded later
  trials[1].converged = trials[1].unfolded = true, trials[1].regrasps = 4;
  trials[2].belief_step = -1;  // never reached f ≥ ξ on a regrasped holder
  const TableRow r = Summarise("shorts", "default", trials);
  EXPECT_EQ(r.unfolded, 2);
  EXPECT_EQ(r.belief_unfolded, 1);
  EXPECT_EQ(r.belief_not_unfolded, 1);
  EXPECT_DOUBLE_EQ(r.belief_regrasps_on_success, 2);
  EXPECT_EQ(r.rejected, 1);
  EXPECT_NE(ReportMarkdown({r}).find("| 0 | 1 / 1 / 2.0 | 1 |"), std::string::npos);
  EXPECT_EQ(ReportJson({r})["rows"][0]["belief_only"]["declared_not_unfolded"], 1);
}

// Trouser leg ends 40 cm apart on the pattern, and a knee.
Garment LegEnds() {
  Garment g;
  g.category = "pants";
  g.anchors = {{"left_leg_outer", Vec2(-0.2, 0)}, {"right_leg_outer", Vec2(0.2, 0)}, {"left_knee", Vec2(-0.2, 0.4)}};
  return g;
}

TEST(Success, PairDistanceIsTheFartherGripOfTheBetterAssignment) {
  const Garment g = LegEnds();
  const auto pairs = DesiredPairsFor("pants");
  // 3 cm and 5 cm from the leg ends: the farther one counts, whichever gripper holds which.
  EXPECT_NEAR(DesiredPairDistance(g, pairs, Vec2(-0.2, 0.03), Vec2(0.25, 0)), 0.05, 1e-12);
  EXPECT_NEAR(DesiredPairDistance(g, pairs, Vec2(0.25, 0), Vec2(-0.2, 0.03)), 0.05, 1e-12);
  // Both on the left leg end: the right one is 40 cm away.
  EXPECT_NEAR(DesiredPairDistance(g, pairs, Vec2(-0.2, 0), Vec2(-0.2, 0)), 0.4, 1e-12);
  EXPECT_EQ(DesiredPairDistance(g, DesiredPairsFor("long_sleeve_shirt"), Vec2(0, 0), Vec2(0, 0)), -1);  // no elbows
}

TEST(Report, CountsTheConvergedTrialsWithinEachDistance) {
  std::vector<TrialResult> trials(5);
  const double d[] = {0.03, 0.059, 0.07, 0.2, 0.01};
  for (int i = 0; i < 5; ++i) {
    trials[i].converged = i != 4;  // the last stopped short of f ≥ ξ: never counted
    trials[i].final_pair_distance = d[i];
    trials[i].unfolded = trials[i].converged && d[i] <= 0.06;
  }
  const TableRow r = Summarise("pants", "default", trials);
  EXPECT_EQ(r.unfolded, 2);
  EXPECT_EQ(r.unfolded_within, (std::array<int, 4>{1, 2, 3, 3}));
  EXPECT_EQ(r.declared_not_unfolded, 2);  // 7 and 20 cm off at f ≥ ξ; the unconverged one is not declared
  EXPECT_NE(ReportMarkdown({r}).find("| 2 | 0 / 0 / – | 0 | 1 / 2 / 3 / 3 |"), std::string::npos);
  EXPECT_EQ(ReportJson({r})["rows"][0]["unfolded_within_m"]["0.08"], 3);
  EXPECT_EQ(ReportJson({r})["rows"][0]["declared_not_unfolded"], 2);
}

}  // namespace
}  // namespace drape::unfolding
