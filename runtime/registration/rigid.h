// Scaling and rigid ICP (paper §"Deformable Registration", steps 1 and 2).
#pragma once

#include <vector>

#include "common/mesh.h"
#include "runtime/registration/grid.h"

namespace drape::registration {

// Area-weighted centre c = Σ a_i g_i / Σ a_i and representative size
// l = Σ a_i ‖g_i − c‖ / Σ a_i over triangles (a_i area, g_i barycentre). Metres.
struct MeshFrame {
  Vec3 centre = Vec3::Zero();
  double size = 0;
  double area = 0;
};
// Throws drape::Error if the mesh has no area.
MeshFrame AreaWeightedFrame(const TriMesh& mesh);

// x ↦ scale · R x + t.
struct Similarity {
  double scale = 1;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Vec3 translation = Vec3::Zero();
  Vec3 Apply(const Vec3& x) const { return scale * (rotation * x) + translation; }
  Points3 Apply(const Points3& V) const;
  // (this ∘ first): apply `first`, then this.
  Similarity After(const Similarity& first) const;
  Eigen::Matrix4d Matrix() const;
};

// The paper's scaling: scale the source by l_T / l_S about its centre and move its
// centre onto the target's centre.
Similarity ScaleToTarget(const MeshFrame& source, const MeshFrame& target);

struct IcpOptions {
  int max_iterations = 100;
  double angle_tolerance = 1e-5;        // radians per iteration: converged below both
  double translation_tolerance = 1e-5;  // metres per iteration
  bool refined_query = true;            // exact distance to the ≤8 stored triangles; false: the paper's 8-point query
  void Validate() const;
};

struct IcpReport {
  int iterations = 0;
  bool converged = false;
  double rms_before = 0, rms_after = 0;  // RMS vertex-to-target distance (grid query), m
  double last_angle = 0, last_translation = 0;
  double seconds = 0;  // timing only
};

// Point-to-point ICP of the vertices V (in place) against the grid's target: per
// iteration closest points from the grid, the optimal rotation + translation in closed
// form (Umeyama without scaling), applied; stops when one iteration's motion is below
// both tolerances. Returns the accumulated rigid motion.
Similarity Icp(Points3& V, const ClosestPointGrid& grid, const IcpOptions& options, IcpReport* report);

}  // namespace drape::registration
