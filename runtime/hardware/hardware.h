// Robot hardware for regrasping and unfolding, as interfaces a real robot driver could
// implement (a Baxter-like dual-arm robot: two parallel grippers with tactile sensing,
// an IR range sensor beside each gripper, a Kinect on the head, a table), and the
// vocabulary they share. Simulated implementations are in sim.h.
//
// Frames and units: world frame, metres, seconds, y up (docs/architecture.md,
// "Conventions every stage follows"). A gripper pose is its jaw centre (the point
// between the fingertips where cloth is pinched), the approach direction (unit, from the
// palm towards the fingertips) and the closing direction (unit, perpendicular to
// approach: the fingers move along it).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/mesh.h"
#include "generator/sweep/sweep.h"

namespace drape::hardware {

struct GripperPose {
  Vec3 position = Vec3::Zero();
  Vec3 approach = -Vec3::UnitY();  // fingers point down
  Vec3 closing = Vec3::UnitX();
  double wrist = 0;  // radians about the vertical through the jaws (turning a held garment)
};

// A time-parameterised path: poses at times (s, from the start of the move).
struct PathPoint {
  double time = 0;
  GripperPose pose;
};
using Path = std::vector<PathPoint>;

// What closing the jaws did (the tactile check tells a real driver the first three).
enum class GraspOutcome {
  kMiss,        // nothing between the jaws
  kOneLayer,    // pinched one layer of fabric
  kBothLayers,  // pinched both layers (or a seam)
  kLost,        // was holding, and the garment slipped out
};
const char* GraspOutcomeName(GraspOutcome o);

struct GraspReport {
  GraspOutcome outcome = GraspOutcome::kMiss;
  int captured = 0;           // simulation: cloth nodes between the jaws
  Vec3 point = Vec3::Zero();  // world position of the pinch (jaw centre)
  std::string note;
};

class Arm {
 public:
  virtual ~Arm() = default;
  virtual std::string name() const = 0;
  virtual GripperPose pose() const = 0;
  // Moves along the path (its last point is where the gripper ends); returns the
  // seconds it took. A held garment follows the gripper.
  virtual double Move(const Path& path) = 0;
  virtual GraspReport Close() = 0;
  virtual void Open() = 0;
  // The tactile check: true while the closed jaws hold cloth.
  virtual bool HoldsCloth() const = 0;
  // Jaw opening (m): the width of cloth the gripper can take.
  virtual double jaw_opening() const = 0;
};

// A straight-line path from `from` to `to` at `speed` (m/s), `steps` segments, with the
// orientation of `to` throughout (the wrist turns before moving).
Path StraightPath(const GripperPose& from, const GripperPose& to, double speed = 0.25, int steps = 10);

// A depth camera that watches a garment held by `holder` while the holder's wrist
// turns (paper: 360° one way and back, ~550 frames). Frames carry camera_to_object
// poses in the holder's jaw frame (grasp point at the origin, y up), as the
// generator's sweeps do, so fusion treats the turning garment as a static scene.
struct CaptureOptions {
  int frames = 550;            // total, both directions
  double degrees = 360;        // one way
  bool back_and_forth = true;  // then back
  void Validate() const;
};
class DepthCamera {
 public:
  virtual ~DepthCamera() = default;
  virtual Sweep CaptureTurning(Arm& holder, const CaptureOptions& options, uint64_t seed) = 0;
};

// A single-beam range sensor mounted beside a gripper, looking along its approach
// direction (Baxter's hand IR sensor).
class RangeSensor {
 public:
  virtual ~RangeSensor() = default;
  // Metres from the sensor to the first surface along the approach; +inf if nothing lies
  // within [min_range, max_range].
  virtual double Read() = 0;
  // Where the sensor sits relative to the jaw centre, in the gripper's frame
  // (x = closing, y = approach × closing, z = approach), metres.
  virtual Vec3 mount() const = 0;
  virtual double max_range() const = 0;
};

// A table to lay the garment on: its top surface (an axis-aligned box, metres).
class Table {
 public:
  virtual ~Table() = default;
  virtual Eigen::AlignedBox3d top() const = 0;
};

}  // namespace drape::hardware
