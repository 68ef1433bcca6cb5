// Folding plans as data (runtime/folding/plans/README.md documents the format and
// plan.schema.json is its JSON Schema): a list of steps, each a fold line and the key
// points one or two arms grasp; each grasped point goes to its mirror image across the
// fold line (the ideal fold, the same one that defines the step's target shape S_t).
// Points are key points found on the flat garment's top-down mask (keypoints.h),
// optionally interpolated between two key points and offset.
//
// Parsing is strict, like recipes: an unknown or misspelt key, a wrong type, an
// out-of-range value or a key point the plan's categories do not have throws
// drape::Error "FILE:LINE:COL: key.path: what".
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "common/mesh.h"
#include "runtime/folding/gripper.h"

namespace drape::folding {

// A point of the plan, in the garment frame of the top-down picture: x to the picture's
// right (the wearer's left), y towards the collar/waist; metres.
// position = K(a) + t·(K(b) − K(a)) + offset (b empty: K(a) + offset).
struct PlanPoint {
  std::string a, b;
  double t = 0;
  Vec2 offset = Vec2::Zero();
  int line = 0;  // 1-based line in the plan file (for messages)
};

struct PlanStep {
  std::string name;
  PlanPoint line_from, line_to;   // the fold line through two points
  std::vector<PlanPoint> grasps;  // one per arm (1 or 2); arm 0 = the robot's left
  // The gripper this step uses (a single layer by a point, a stack by a pinch); unset:
  // the run's default (`drape fold --gripper`).
  std::optional<GripperModel> gripper;
  int line = 0;
};

struct FoldingPlan {
  std::string file_label;  // what messages call the file
  std::string name;
  std::string description;
  std::vector<std::string> categories;  // garment categories it applies to
  std::vector<PlanStep> steps;
};

// Parses plan text; file_label names the file in errors.
FoldingPlan ParsePlan(const std::string& text, const std::string& file_label);
// Reads and parses a file (errors name the path as given).
FoldingPlan LoadPlan(const std::filesystem::path& path);

}  // namespace drape::folding
