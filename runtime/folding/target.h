// Target shape S_t of a folding step (paper §"Trajectory Optimization"): the ideal
// geometric fold of the current mesh about the fold line — the part on the grasped
// side turned over about the line, on top of the rest, one cloth thickness above the
// stack. The same map sends each grasp point to its target P3.
#pragma once

#include <limits>

#include "common/mesh.h"

namespace drape::folding {

// A line on the table through `point` along `direction` (world x, z; metres).
struct FoldLine {
  Vec2 point = Vec2::Zero();
  Vec2 direction = Vec2::UnitX();
};

// A half-turn (π) about a horizontal axis over the fold line at `axis_height`: a point
// p on the folded side goes to its mirror image across the line in x–z and to height
// 2·axis_height − p.y (the stack's top layer comes to rest `thickness` above it, the
// bottom layer on top). Points on the other side stay.
class IdealFold {
 public:
  // `grasp` (world x, z) picks the folded side; axis_height = the highest current vertex
  // the fold concerns + thickness/2: those on the folded side and those it lands on
  // (within `reach` in x–z of a folded vertex's mirror image; pass the mesh's longest
  // edge). A bump elsewhere (the first sleeve's shoulder, 6.6 cm high at 8 cm) must not
  // lift the second sleeve's target. No vertex on the folded side: the highest of all.
  // Throws drape::Error if the line is degenerate or `grasp` lies on it.
  IdealFold(const FoldLine& line, const Vec2& grasp, const Points3& current, double thickness,
            double reach = std::numeric_limits<double>::infinity());

  bool Folds(const Vec3& p) const;  // on the folded side (strictly)
  Vec3 Apply(const Vec3& p) const;  // the fold's image of p (identity off the folded side)
  // The rotation that turns the folded side over, by angle·π (angle in [0, 1]); the
  // sign makes the folded side pass above the axis.
  Eigen::Matrix3d Rotation(double fraction) const;
  const FoldLine& line() const { return line_; }
  double axis_height() const { return axis_height_; }
  double thickness() const { return thickness_; }
  double reach() const { return reach_; }
  Vec3 Axis() const { return Vec3(line_.direction.x(), 0, line_.direction.y()); }

 private:
  double Side(const Vec3& p) const;                             // signed distance, > 0 on the folded side
  double StackTop(const Points3& current, double reach) const;  // see the constructor
  FoldLine line_;
  Vec2 normal_;  // unit, towards the folded side
  double axis_height_ = 0, thickness_ = 0, reach_ = 0;
};

// S_t: every vertex of `current` mapped by the fold (faces unchanged).
TriMesh TargetShape(const TriMesh& current, const IdealFold& fold);

// The plan's ideal shape after `fold` acts on an ideal stack of layers (PlanSteps): the
// folded side goes to its mirror image in x–z as in IdealFold, but each folded part
// lands upside down on what lies under its image, one thickness above it:
//   y' = (top under the image) + thickness + (top of the folded part at p − p.y),
// "at" a place = within the fold's reach of it in x–z (the mesh's longest edge: one
// column of layers); under nothing, on the table (the lowest vertex − thickness). On an even
// stack it is IdealFold's half-turn. IdealFold turns the folded part rigidly about the
// higher of its own top and the top it lands on (a step's target and P3, where the
// cloth's loops must not be turned over below the table); chained on a plan's ideal,
// that left a gap wherever a flap lands beside a thicker stack, doubled at every later
// fold: the shirt's ideal stood 21.9 cm high after five folds at 8 cm.
TriMesh LandedFold(const TriMesh& stack, const IdealFold& fold);

// The longest edge of a mesh (IdealFold's reach), m.
double LongestEdge(const TriMesh& mesh);

}  // namespace drape::folding
