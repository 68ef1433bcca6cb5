// Folding plans: the shipped plans parse (paper's step counts), and bad plans fail
// with FILE:LINE:COL and the key path.
#include "runtime/folding/plan.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "common/error.h"
#include "common/source_dir.h"

namespace drape::folding {
namespace {

const std::filesystem::path kPlans = SourceDir() / "runtime/folding/plans";

// The paper's step counts, except the shirt's: its sleeves are folded down first.
TEST(Plan, ShippedPlansParseWithTheirStepCounts) {
  const std::map<std::string, size_t> steps = {
      {"long_sleeve_shirt", 5}, {"pants", 2}, {"towel", 2}, {"shorts", 2}, {"tshirt", 3}};
  for (const auto& [name, n] : steps) {
    const FoldingPlan p = LoadPlan(kPlans / (name + ".yaml"));
    EXPECT_EQ(p.name, name);
    EXPECT_EQ(p.steps.size(), n) << name;
    ASSERT_EQ(p.categories.size(), 1u);
    EXPECT_EQ(p.categories[0], name);
    for (const auto& s : p.steps) EXPECT_GE(s.grasps.size(), 1u);
  }
}

TEST(Plan, PointForms) {
  const FoldingPlan p = ParsePlan(R"(plan: t
categories: [towel]
steps:
  - name: a
    fold_line: [top_left, {between: [top_left, top_right], t: 0.25, offset: [0.01, -0.02]}]
    grasp: [{at: bottom_left, offset: [0.03, 0.04]}]
)",
                                  "t.yaml");
  ASSERT_EQ(p.steps.size(), 1u);
  const PlanStep& s = p.steps[0];
  EXPECT_EQ(s.line, 4);
  EXPECT_EQ(s.line_from.a, "top_left");
  EXPECT_TRUE(s.line_from.b.empty());
  EXPECT_EQ(s.line_to.b, "top_right");
  EXPECT_DOUBLE_EQ(s.line_to.t, 0.25);
  EXPECT_DOUBLE_EQ(s.line_to.offset.y(), -0.02);
  EXPECT_EQ(s.grasps[0].a, "bottom_left");
  EXPECT_DOUBLE_EQ(s.grasps[0].offset.x(), 0.03);
  EXPECT_EQ(s.grasps[0].line, 6);
}

// A step may name its gripper; one that does not takes the run's (unset here).
TEST(Plan, StepGripper) {
  const FoldingPlan p = ParsePlan(R"(plan: t
categories: [towel]
steps:
  - name: a
    fold_line: [top_left, top_right]
    grasp: [bottom_left]
    gripper: point
  - name: b
    fold_line: [top_left, top_right]
    grasp: [bottom_left]
  - name: c
    gripper: pinch
    fold_line: [top_left, top_right]
    grasp: [bottom_left]
)",
                                  "t.yaml");
  ASSERT_EQ(p.steps.size(), 3u);
  EXPECT_EQ(p.steps[0].gripper, GripperModel::kPoint);
  EXPECT_FALSE(p.steps[1].gripper.has_value());
  EXPECT_EQ(p.steps[2].gripper, GripperModel::kPinch);
}

// The error message of parsing `text`, or "" if it parsed.
std::string ErrorOf(const std::string& text) {
  try {
    ParsePlan(text, "bad.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Plan, ErrorsNameFileLineAndKey) {
  const std::string head = "plan: t\ncategories: [towel]\nsteps:\n  - name: a\n";
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left, top_right]\n    grasp: [bottom_left]\n    speed: 2\n"),
            "bad.yaml:7:5: steps[0].speed: unknown key; known keys here: name, fold_line, grasp, gripper");
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left, top_right]\n    grasp: [bottom_left]\n    gripper: claw\n"),
            "bad.yaml:7:14: steps[0].gripper: 'claw' is not point or pinch");
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left, top_right]\n    grasp: [bottom_left]\n    gripper: [point]\n"),
            "bad.yaml:7:14: steps[0].gripper: expected a string, got a list");
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left, top_right]\n    grasp: [bottom_left]\n    gripper: point\n"
                           "    gripper: pinch\n"),
            "bad.yaml:8:5: steps[0].gripper: key given twice");
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left, top_rihgt]\n    grasp: [bottom_left]\n").substr(0, 62),
            "bad.yaml:5:27: steps[0].fold_line[1]: unknown key point 'top_r");
  EXPECT_EQ(
      ErrorOf(head + "    fold_line: [top_left, {between: [top_left, top_right], t: 3}]\n    grasp: [bottom_left]\n"),
      "bad.yaml:5:63: steps[0].fold_line[1].t: out of range: 3 (allowed [-1, 2])");
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left]\n    grasp: [bottom_left]\n"),
            "bad.yaml:5:16: steps[0].fold_line: expected a list of two points");
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left, top_right]\n    grasp: [bottom_left, top_left, center]\n"),
            "bad.yaml:6:12: steps[0].grasp: expected a list of one or two points (one per arm)");
  EXPECT_EQ(ErrorOf(head + "    fold_line: [top_left, top_right]\n"), "bad.yaml:4:5: steps[0]: missing key 'grasp'");
  EXPECT_EQ(ErrorOf("plan: t\ncategories: [sock]\nsteps: []\n").substr(0, 44),
            "bad.yaml:2:14: categories[0]: no key point d");
  EXPECT_EQ(ErrorOf("plan: t\ncategories: [towel]\nsteps: [\n"),
            "bad.yaml:4:1: YAML syntax error: end of sequence flow not found");
  // A key point the category lacks: pants have no collar.
  EXPECT_NE(ErrorOf("plan: t\ncategories: [pants]\nsteps:\n  - name: a\n    fold_line: [crotch, collar]\n"
                    "    grasp: [crotch]\n")
                .find("bad.yaml:5:25: steps[0].fold_line[1]: unknown key point 'collar'"),
            std::string::npos);
  EXPECT_NE(ErrorOf(head + "    fold_line: [top_left, top_right]\n    grasp: [bottom_left]\n  - name: a\n"
                           "    fold_line: [top_left, top_right]\n    grasp: [bottom_left]\n")
                .find("bad.yaml:7:11: steps[1].name: step name 'a' given twice"),
            std::string::npos);
}

}  // namespace
}  // namespace drape::folding
