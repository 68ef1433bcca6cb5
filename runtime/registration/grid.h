// Closest-point grid over a target mesh (paper §"Deformable Registration", after
// Tsai 2002): every node of a regular grid stores the closest point on the target, the
// triangle it lies on and its distance. Exact values in a narrow band around the
// surface, then Gauss–Seidel fast sweeping in the 8 diagonal orderings propagates
// closest-triangle candidates from upwind neighbours to the rest of the grid. A query
// looks only at the 8 nodes of the cell holding the point: O(1).
#pragma once

#include <cstdint>
#include <vector>

#include "common/closest_point.h"
#include "common/mesh.h"

namespace drape::registration {

struct GridOptions {
  int cells = 64;                 // grid cells along the longest side of the padded box
  double padding = 0.1;           // box padding on every side, as a fraction of the longest side
  double band = 1.5;              // narrow band half-width (in cells) where values are exact
  int max_passes = 2;             // rounds of the 8 sweeps (stops early when nothing changes)
  int64_t max_nodes = 6'000'000;  // refuse larger grids (memory: 20 bytes per node)
  int threads = 0;                // narrow-band threads (<= 0: all cores); results do not depend on it
  void Validate() const;          // throws drape::Error naming the bad field
};

struct GridStats {
  int nx = 0, ny = 0, nz = 0;
  double spacing = 0;                          // h, metres
  int64_t band_nodes = 0;                      // nodes given an exact value by the narrow band
  int passes = 0;                              // sweep rounds run (8 orderings each)
  int64_t sweep_updates = 0;                   // node improvements made by sweeping
  double band_seconds = 0, sweep_seconds = 0;  // timing only
};

class ClosestPointGrid {
 public:
  // Builds the grid over `target` (copied). Throws drape::Error for an empty mesh or a
  // grid larger than options.max_nodes.
  ClosestPointGrid(const TriMesh& target, const GridOptions& options = {});

  // The paper's query: among the closest points stored at the 8 corners of the cell
  // holding p (clamped to the grid), the one nearest to p. Error bound: see grid_test.
  ClosestPoint Query(const Vec3& p) const;
  // Refined O(1) query: the exact closest point on the (at most 8) triangles stored at
  // the cell's corners. Continuous inside a cell; used for the non-rigid fitting term.
  ClosestPoint QueryRefined(const Vec3& p) const;

  // Stored value of node (i, j, k).
  ClosestPoint Node(int i, int j, int k) const;
  Vec3 NodePosition(int i, int j, int k) const;
  const TriMesh& target() const { return target_; }
  const GridStats& stats() const { return stats_; }
  double spacing() const { return h_; }

 private:
  struct Cell {
    float p[3];
    float d;
    int32_t tri;
  };
  int64_t Index(int i, int j, int k) const { return (int64_t(k) * ny_ + j) * nx_ + i; }
  void CellCorners(const Vec3& p, int64_t corners[8]) const;
  // The constructor's steps: the exact narrow band, then fast sweeping outwards.
  void FillBand(const GridOptions& options);
  void Sweep(const GridOptions& options);
  int64_t SweepOrder(int order);  // one Gauss–Seidel pass in one diagonal order; updates

  TriMesh target_;
  Vec3 origin_ = Vec3::Zero();
  double h_ = 0;
  int nx_ = 0, ny_ = 0, nz_ = 0;
  std::vector<Cell> nodes_;
  GridStats stats_;
};

}  // namespace drape::registration
