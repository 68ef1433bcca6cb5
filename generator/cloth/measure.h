// What a simulated cloth mesh is measured by before it is published: does it pass
// through itself (CGAL's exact self-intersection test), how close do its non-adjacent
// elements come, how far are its edges stretched.
#pragma once

#include <array>
#include <vector>

#include "common/mesh.h"

namespace drape {

// Pairs of faces (f < g) of `mesh` whose triangles intersect other than in a vertex or
// an edge they share: CGAL::Polygon_mesh_processing::self_intersections on a
// Surface_mesh with the Epick kernel (exact predicates). When the mesh is not a valid
// halfedge mesh (a non-manifold edge or vertex), the same exact tests run on the
// triangle soup (CGAL box intersection + do_intersect; pairs sharing a vertex or an
// edge are tested as CGAL does) and *as_soup is set. Zero-area faces are not pairs;
// they are counted in *degenerate_faces.
std::vector<std::array<int, 2>> SelfIntersectingFacePairs(const TriMesh& mesh, bool* as_soup = nullptr,
                                                          int* degenerate_faces = nullptr);

// Edge strain (l − L0)/L0 over the unique mesh edges of F, rest positions → x.
// Percentiles are nearest-rank on the sorted strains.
struct EdgeStrain {
  double mean = 0, median = 0, p99 = 0, max = 0, min = 0;
  int edges = 0;
};
EdgeStrain MeasureEdgeStrain(const Faces& F, const Points3& rest, const Points3& x);

struct ClothMeasurement {
  int intersecting_pairs = 0;  // SelfIntersectingFacePairs().size()
  int degenerate_faces = 0;
  bool measured_as_soup = false;
  double min_distance = 0;  // m, MinimumNonAdjacentDistance (collision.h)
  EdgeStrain strain;
};
// mesh: the simulated state; rest: its rest (flat) positions, same vertex order.
ClothMeasurement MeasureCloth(const TriMesh& mesh, const Points3& rest);

}  // namespace drape
