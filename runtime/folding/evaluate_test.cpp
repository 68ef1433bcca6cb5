// Seeded trials: a failure inside one trial (here the key points a plan needs are not
// on the garment) marks that trial failed with its reason and the next trial still
// runs; a trial that completes is judged by the stated criterion.
#include "runtime/folding/evaluate.h"

#include <gtest/gtest.h>

#include "generator/cloth/rectangle.h"
#include "runtime/folding/plan.h"

namespace drape::folding {
namespace {

FoldSetup SmallSetup(const std::string& category) {
  FoldSetup s;
  s.garment = MakeRectangleGarment(0.30, 0.20, 0.05, true);
  s.garment.category = category;
  s.material.area_density = 0.3;
  s.material.link_stiffness = 0.6;
  s.material.max_strain = 0.06;
  return s;
}

std::vector<std::vector<RelativeTrajectory>> Initial(size_t steps, size_t arms) {
  const RelativeTrajectory h3{Vec3(1.0 / 3, 1.0 / 3, 0), Vec3(2.0 / 3, 1.0 / 3, 0), std::nullopt};
  return std::vector<std::vector<RelativeTrajectory>>(steps, std::vector<RelativeTrajectory>(arms, h3));
}

// One step: the towel's bottom half over its top half, held at both bottom corners;
// `extra` adds keys to the step (e.g. its gripper).
FoldingPlan TowelInHalf(const std::string& extra = "") {
  return ParsePlan(
      "plan: t\ncategories: [towel]\nsteps:\n"
      "  - name: bottom_up\n    fold_line:\n"
      "      - {between: [bottom_left, top_left], t: 0.5}\n"
      "      - {between: [bottom_right, top_right], t: 0.5}\n"
      "    grasp: [bottom_left, bottom_right]\n" +
          extra,
      "test.yaml");
}

// A w × w square on the table (world x, z), its corner at (x0, z0).
TriMesh Square(double w, double x0, double z0) {
  TriMesh m;
  m.V.resize(4, 3);
  m.V << x0, 0, z0, x0 + w, 0, z0, x0 + w, 0, z0 + w, x0, 0, z0 + w;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 0, 2, 3;
  return m;
}

TEST(Silhouette, InsideFractionAndReachOfAShiftedSquare) {
  // A 0.3 m square shifted by s = 6 cm along x: the strip outside the reference is 20 %
  // of it, its pixels 0..s from the reference, so q of the shape lies within
  // s − (1 − q)·0.3 of it: 3 cm for q = 0.9, 4.5 cm for q = 0.95.
  const TriMesh ref = Square(0.3, 0, 0), shifted = Square(0.3, 0.06, 0);
  const double px = 0.002;
  EXPECT_EQ(SilhouetteReach(ref, ref, 0.9, px), 0.0);
  EXPECT_NEAR(SilhouetteInside(ref, ref, 0.0, px), 1.0, 1e-12);
  EXPECT_NEAR(SilhouetteReach(shifted, ref, 0.9, px), 0.03, 2 * px);
  EXPECT_NEAR(SilhouetteReach(shifted, ref, 0.95, px), 0.045, 2 * px);
  EXPECT_NEAR(SilhouetteInside(shifted, ref, 0.0, px), 0.8, 0.02);
  EXPECT_NEAR(SilhouetteInside(shifted, ref, 0.03, px), 0.9, 0.02);
  EXPECT_NEAR(SilhouetteInside(shifted, ref, 0.06, px), 1.0, 0.01);
}

TEST(Trials, KeyPointFailureMarksTheTrialAndTheNextOneRuns) {
  // A rectangle called pants has no crotch notch: the plan cannot find its key points.
  const FoldingPlan plan = ParsePlan(
      "plan: p\ncategories: [pants]\nsteps:\n"
      "  - name: leg_over_leg\n    fold_line: [waist_center, crotch]\n    grasp: [left_waist]\n",
      "test.yaml");
  TrialOptions o;
  o.trials = 3;
  int seen = 0;
  const auto trials = RunTrials(SmallSetup("pants"), plan, PlanRunOptions{}, Initial(1, 1), o,
                                [&](const TrialResult& t) { EXPECT_EQ(t.index, seen++); });
  ASSERT_EQ(trials.size(), 3u);
  EXPECT_EQ(seen, 3);
  for (const TrialResult& t : trials) {
    EXPECT_FALSE(t.success);
    EXPECT_FALSE(t.completed);
    EXPECT_NE(t.failure.find("crotch"), std::string::npos) << t.failure;
    EXPECT_GT(t.run.flat.rows(), 0);  // the settled garment the camera looked at is kept
    EXPECT_TRUE(t.run.steps.empty());
  }
  // Seeded: each trial its own perturbation, the same for the same seed.
  EXPECT_NE(trials[0].friction_scale, trials[1].friction_scale);
  EXPECT_EQ(RunTrial(SmallSetup("pants"), plan, PlanRunOptions{}, Initial(1, 1), o, 1).friction_scale,
            trials[1].friction_scale);
}

TEST(Trials, ACompletedTrialIsJudged) {
  const FoldingPlan plan = TowelInHalf();
  TrialOptions o;
  o.trials = 1;
  // Knots as high as the fold is wide (fold_test: this folds the small cloth).
  std::vector<std::vector<RelativeTrajectory>> high(
      1,
      std::vector<RelativeTrajectory>(2, RelativeTrajectory{Vec3(1.0 / 3, 1, 0), Vec3(2.0 / 3, 1, 0), std::nullopt}));
  const TrialResult t = RunTrial(SmallSetup("towel"), plan, PlanRunOptions{}, high, o, 0);
  ASSERT_TRUE(t.completed) << t.failure;
  ASSERT_EQ(t.run.steps.size(), 1u);
  EXPECT_NEAR(t.diagonal, std::hypot(0.30, 0.20), 0.02);
  EXPECT_GT(t.sim_time, 0);
  EXPECT_EQ(t.success, t.failure.empty());
  EXPECT_EQ(t.success, t.final_dissimilarity <= o.d_fraction * t.diagonal && t.inside_fraction >= o.inside);
  EXPECT_GE(t.reach, 0.0);
  std::printf("small towel trial: D %.1f mm (%.1f %% of %.3f m), %.0f %% inside, %s\n", 1e3 * t.final_dissimilarity,
              100 * t.final_dissimilarity / t.diagonal, t.diagonal, 100 * t.inside_fraction,
              t.success ? "success" : t.failure.c_str());
}

// A replay of a run's own trajectories on its own garment is that run, bit for bit: the
// relative form's round trip (~1e-16 m) must not reach the cloth, which would grow it.
TEST(Replay, TheRunsOwnTrajectoriesOnItsOwnGarmentReproduceItExactly) {
  const FoldingPlan plan = TowelInHalf();
  const FoldSetup setup = SmallSetup("towel");
  const FoldScene scene = MakeScene(setup);
  PlanRunOptions o;
  o.optimise.lm.max_iterations = 2;
  const PlanRun run = RunPlan(scene, LaidGarment(setup), "towel", plan, o);
  ASSERT_EQ(run.steps.size(), 1u);
  std::vector<std::vector<RelativeTrajectory>> replay;
  for (const StepRecord& s : run.steps) replay.push_back(s.relative);
  const PlanRun again = RunPlan(scene, LaidGarment(setup), "towel", plan, o, &replay);
  EXPECT_TRUE((again.final.array() == run.final.array()).all());
  EXPECT_EQ(again.final_dissimilarity, run.final_dissimilarity);
  // Without the source path the knots go through the fold frame and back.
  for (auto& arm : replay[0]) arm.source.reset();
  const PlanRun framed = RunPlan(scene, LaidGarment(setup), "towel", plan, o, &replay);
  EXPECT_NEAR(framed.final_dissimilarity, run.final_dissimilarity, 0.01);
  std::printf("replay: D %.6f mm exact, %.6f mm through the fold frame (run %.6f mm)\n",
              1e3 * again.final_dissimilarity, 1e3 * framed.final_dissimilarity, 1e3 * run.final_dissimilarity);
}

// A plan step that names its gripper uses it whatever the run's default; a step that
// does not takes the default. (On this mesh both models hold one node per corner; the
// jaws differ, and so does the fold.)
TEST(Replay, AStepsGripperOverridesTheRunsDefault) {
  const FoldSetup setup = SmallSetup("towel");
  const FoldScene scene = MakeScene(setup);
  const std::vector<std::vector<RelativeTrajectory>> replay = Initial(1, 2);
  auto run = [&](const FoldingPlan& plan, GripperModel fallback) {
    PlanRunOptions o;
    o.sim.gripper = fallback;
    PlanRun r = RunPlan(scene, LaidGarment(setup), "towel", plan, o, &replay);
    EXPECT_EQ(r.steps.size(), 1u);
    return r;
  };
  const PlanRun point = run(TowelInHalf(), GripperModel::kPoint), pinch = run(TowelInHalf(), GripperModel::kPinch);
  EXPECT_EQ(point.steps[0].gripper, GripperModel::kPoint);
  EXPECT_EQ(pinch.steps[0].gripper, GripperModel::kPinch);
  ASSERT_FALSE((point.final.array() == pinch.final.array()).all());
  const PlanRun named_point = run(TowelInHalf("    gripper: point\n"), GripperModel::kPinch);
  EXPECT_EQ(named_point.steps[0].gripper, GripperModel::kPoint);
  EXPECT_TRUE((named_point.final.array() == point.final.array()).all());
  const PlanRun named_pinch = run(TowelInHalf("    gripper: pinch\n"), GripperModel::kPoint);
  EXPECT_EQ(named_pinch.steps[0].gripper, GripperModel::kPinch);
  EXPECT_TRUE((named_pinch.final.array() == pinch.final.array()).all());
}

}  // namespace
}  // namespace drape::folding
