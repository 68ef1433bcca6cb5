// Mesh and garment checks shared by the templates, imports and tests: topology
// (manifold edges, orientation, boundary loops, components), geometry (finite
// coordinates, degenerate faces, edge lengths, angles) and anchors.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "garments/garment.h"

namespace drape {

// What InspectMesh measured. Lengths in metres, areas in m², angles in degrees.
struct MeshReport {
  int vertices = 0, faces = 0;
  int components = 0;             // over faces (common/mesh.h ConnectedComponents)
  int unreferenced_vertices = 0;  // vertices used by no face
  int boundary_edges = 0;
  int boundary_loops = 0;                             // connected groups of boundary edges
  std::vector<std::array<int, 2>> nonmanifold_edges;  // edges with more than two faces
  int inconsistent_edges = 0;                         // interior edges whose two faces run the same way
  std::vector<int> degenerate_faces;                  // repeated index or 2·area/longest² < 1e-6
  std::vector<int> nonfinite_vertices;
  std::vector<int> bad_index_faces;  // faces naming a vertex out of range
  double edge_min = 0, edge_mean = 0, edge_max = 0, edge_p05 = 0, edge_p95 = 0;
  double min_angle_deg = 0;
  double area = 0;
  Vec3 bounds_min = Vec3::Zero(), bounds_max = Vec3::Zero();

  bool Manifold() const { return nonmanifold_edges.empty(); }
  bool Oriented() const { return inconsistent_edges == 0; }
};

// Measures a mesh; never throws on bad content (reports it instead).
MeshReport InspectMesh(const TriMesh& mesh);

struct ValidationOptions {
  double max_anchor_distance = 0.02;  // metres from the surface
  bool require_oriented = false;      // imports may come with mixed winding
};

// Every problem found, each one line naming `where` (usually the file) and the
// element: "shirt.ply: face 12 (3, 4, 5) is degenerate (area 0 m²)". Empty = valid.
std::vector<std::string> CheckGarment(const Garment& garment, const std::string& where,
                                      const ValidationOptions& options = {});

// Throws drape::Error with the first problem (and how many more there are).
void ValidateGarment(const Garment& garment, const std::string& where, const ValidationOptions& options = {});

// Smallest distance from p to the mesh surface (brute force over faces), metres.
double DistanceToSurface(const TriMesh& mesh, const Vec3& p);

}  // namespace drape
