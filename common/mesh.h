// Triangle meshes: the currency between garments, simulation, sensing and registration.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace drape {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
// Row-major so that a vertex's x, y, z are contiguous (Embree, PLY buffers).
using Points3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Points2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;
using Faces = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

// V: #V×3 positions in metres. F: #F×3 vertex indices, counter-clockwise when seen
// from the side the face normal points to.
struct TriMesh {
  Points3 V;
  Faces F;

  int NumVertices() const { return static_cast<int>(V.rows()); }
  int NumFaces() const { return static_cast<int>(F.rows()); }
};

// Per-face areas (m²), #F.
Eigen::VectorXd FaceAreas(const TriMesh& mesh);
// Per-face unit normals, #F×3 (zero rows for degenerate faces).
Points3 FaceNormals(const TriMesh& mesh);
// Per-face barycentres, #F×3.
Points3 FaceCentroids(const TriMesh& mesh);
double SurfaceArea(const TriMesh& mesh);
// Area-weighted centre of the surface (uniform density: its centre of mass), m.
Vec3 CentreOfArea(const TriMesh& mesh);
Eigen::AlignedBox3d Bounds(const TriMesh& mesh);

// Undirected edges, each once as {min, max}, sorted.
std::vector<std::array<int, 2>> UniqueEdges(const TriMesh& mesh);

// Edge → incident faces. faces[1] == -1 for a boundary edge; an edge with more
// than two faces is reported in `nonmanifold` (non-empty means the mesh is broken).
struct EdgeFaces {
  std::array<int, 2> edge;
  std::array<int, 2> faces;
};
struct EdgeTopology {
  std::vector<EdgeFaces> edges;  // sorted by edge
  std::vector<std::array<int, 2>> nonmanifold;
};
EdgeTopology BuildEdgeTopology(const TriMesh& mesh);

// Vertex → neighbouring vertices (one ring), sorted.
std::vector<std::vector<int>> VertexNeighbours(const TriMesh& mesh);

// Number of connected components over shared vertices.
int ConnectedComponents(const TriMesh& mesh);

// Closest point on triangle (a, b, c) to p (Ericson, Real-Time Collision Detection §5.1.5).
Vec3 ClosestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace drape
