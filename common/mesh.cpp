#include "common/mesh.h"

#include <algorithm>
#include <map>
#include <numeric>

namespace drape {

Eigen::VectorXd FaceAreas(const TriMesh& mesh) {
  Eigen::VectorXd a(mesh.NumFaces());
  for (int f = 0; f < mesh.NumFaces(); ++f) {
    const Vec3 p0 = mesh.V.row(mesh.F(f, 0)), p1 = mesh.V.row(mesh.F(f, 1)), p2 = mesh.V.row(mesh.F(f, 2));
    a[f] = 0.5 * (p1 - p0).cross(p2 - p0).norm();
  }
  return a;
}

Points3 FaceNormals(const TriMesh& mesh) {
  Points3 n(mesh.NumFaces(), 3);
  for (int f = 0; f < mesh.NumFaces(); ++f) {
    const Vec3 p0 = mesh.V.row(mesh.F(f, 0)), p1 = mesh.V.row(mesh.F(f, 1)), p2 = mesh.V.row(mesh.F(f, 2));
    Vec3 c = (p1 - p0).cross(p2 - p0);
    const double len = c.norm();
    n.row(f) = len > 0 ? Vec3(c / len) : Vec3::Zero();
  }
  return n;
}

Points3 FaceCentroids(const TriMesh& mesh) {
  Points3 g(mesh.NumFaces(), 3);
  for (int f = 0; f < mesh.NumFaces(); ++f)
    g.row(f) = (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))) / 3.0;
  return g;
}

double SurfaceArea(const TriMesh& mesh) { return FaceAreas(mesh).sum(); }

Vec3 CentreOfArea(const TriMesh& mesh) {
  const Eigen::VectorXd area = FaceAreas(mesh);
  Vec3 c = Vec3::Zero();
  for (int f = 0; f < mesh.NumFaces(); ++f)
    c += area[f] * (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))).transpose() / 3;
  return c / area.sum();
}

Eigen::AlignedBox3d Bounds(const TriMesh& mesh) {
  Eigen::AlignedBox3d box;
  for (int i = 0; i < mesh.NumVertices(); ++i) box.extend(Vec3(mesh.V.row(i)));
  return box;
}

std::vector<std::array<int, 2>> UniqueEdges(const TriMesh& mesh) {
  std::vector<std::array<int, 2>> edges;
  edges.reserve(size_t{3} * mesh.NumFaces());
  for (int f = 0; f < mesh.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) {
      int a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3);
      edges.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

EdgeTopology BuildEdgeTopology(const TriMesh& mesh) {
  // (edge, face) pairs sorted by edge, then grouped.
  std::vector<std::pair<std::array<int, 2>, int>> pairs;
  pairs.reserve(size_t{3} * mesh.NumFaces());
  for (int f = 0; f < mesh.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) {
      int a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3);
      pairs.push_back({{std::min(a, b), std::max(a, b)}, f});
    }
  std::sort(pairs.begin(), pairs.end());
  EdgeTopology topo;
  for (size_t i = 0; i < pairs.size();) {
    size_t j = i;
    while (j < pairs.size() && pairs[j].first == pairs[i].first) ++j;
    EdgeFaces ef{pairs[i].first, {pairs[i].second, j - i > 1 ? pairs[i + 1].second : -1}};
    topo.edges.push_back(ef);
    if (j - i > 2) topo.nonmanifold.push_back(pairs[i].first);
    i = j;
  }
  return topo;
}

std::vector<std::vector<int>> VertexNeighbours(const TriMesh& mesh) {
  std::vector<std::vector<int>> nb(mesh.NumVertices());
  for (const auto& e : UniqueEdges(mesh)) {
    nb[e[0]].push_back(e[1]);
    nb[e[1]].push_back(e[0]);
  }
  for (auto& n : nb) std::sort(n.begin(), n.end());
  return nb;
}

int ConnectedComponents(const TriMesh& mesh) {
  std::vector<int> parent(mesh.NumVertices());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int f = 0; f < mesh.NumFaces(); ++f)
    for (int k = 1; k < 3; ++k) parent[find(mesh.F(f, k))] = find(mesh.F(f, 0));
  // Count roots among referenced vertices only.
  std::vector<char> used(mesh.NumVertices(), 0);
  for (int f = 0; f < mesh.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) used[mesh.F(f, k)] = 1;
  int count = 0;
  for (int v = 0; v < mesh.NumVertices(); ++v)
    if (used[v] && find(v) == v) ++count;
  return count;
}

Vec3 ClosestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

}  // namespace drape
