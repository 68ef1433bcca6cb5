#include "garments/validate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>

#include "common/error.h"

namespace drape {
namespace {

std::string Fmt(const Vec3& p) {
  std::ostringstream os;
  os << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return os.str();
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  // Nearest rank; q * (n - 1) >= 0, so floor(x + 0.5) rounds half up.
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::floor(q * static_cast<double>(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// The faces whose indices are valid (the others listed in r.bad_index_faces): only they
// take part in the topology. *good_faces maps back to the input's face numbers.
TriMesh ValidFaces(const TriMesh& mesh, MeshReport& r, std::vector<int>* good_faces) {
  TriMesh good;
  good.V = mesh.V;
  for (int f = 0; f < r.faces; ++f) {
    bool ok = true;
    for (int k = 0; k < 3; ++k) ok &= mesh.F(f, k) >= 0 && mesh.F(f, k) < r.vertices;
    if (ok)
      good_faces->push_back(f);
    else
      r.bad_index_faces.push_back(f);
  }
  good.F.resize(static_cast<int>(good_faces->size()), 3);
  for (size_t i = 0; i < good_faces->size(); ++i) good.F.row(static_cast<int>(i)) = mesh.F.row((*good_faces)[i]);
  return good;
}

// Area, degenerate faces, the smallest angle, unreferenced vertices.
void InspectFaces(const TriMesh& good, const std::vector<int>& good_faces, MeshReport& r) {
  std::vector<char> used(r.vertices, 0);
  double min_angle = 180;
  for (int f = 0; f < good.NumFaces(); ++f) {
    const int a = good.F(f, 0), b = good.F(f, 1), c = good.F(f, 2);
    used[a] = used[b] = used[c] = 1;
    const Vec3 pa = good.V.row(a), pb = good.V.row(b), pc = good.V.row(c);
    const double la = (pb - pc).norm(), lb = (pc - pa).norm(), lc = (pa - pb).norm();
    const double longest = std::max({la, lb, lc});
    const double twice_area = (pb - pa).cross(pc - pa).norm();
    r.area += 0.5 * twice_area;
    if (a == b || b == c || a == c || !(longest > 0) || twice_area / (longest * longest) < 1e-6)
      r.degenerate_faces.push_back(good_faces[f]);
    // Triangle angles by the law of cosines.
    const double l[3] = {la, lb, lc};
    for (int k = 0; k < 3; ++k) {
      const double x = l[k], y = l[(k + 1) % 3], z = l[(k + 2) % 3];
      if (y > 0 && z > 0) {
        const double cosv = std::clamp((y * y + z * z - x * x) / (2 * y * z), -1.0, 1.0);
        min_angle = std::min(min_angle, std::acos(cosv) * 180.0 / M_PI);
      }
    }
  }
  r.min_angle_deg = good.NumFaces() ? min_angle : 0;
  r.unreferenced_vertices = static_cast<int>(std::count(used.begin(), used.end(), 0));
}

// Directed edge counts for orientation; undirected topology for manifoldness, boundary
// edges and loops (union-find over boundary edges) and edge lengths.
void InspectEdges(const TriMesh& good, MeshReport& r) {
  std::map<std::array<int, 2>, int> directed;
  for (int f = 0; f < good.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{good.F(f, k), good.F(f, (k + 1) % 3)}];
  const EdgeTopology topo = BuildEdgeTopology(good);
  r.nonmanifold_edges = topo.nonmanifold;
  std::vector<double> lengths;
  lengths.reserve(topo.edges.size());
  std::vector<int> parent(r.vertices);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::set<int> boundary_vertices;
  for (const EdgeFaces& e : topo.edges) {
    const int a = e.edge[0], b = e.edge[1];
    lengths.push_back((good.V.row(a) - good.V.row(b)).norm());
    if (e.faces[1] < 0) {
      ++r.boundary_edges;
      parent[find(a)] = find(b);
      boundary_vertices.insert(a);
      boundary_vertices.insert(b);
    } else {
      auto ab = directed.find({a, b}), ba = directed.find({b, a});
      const int nab = ab == directed.end() ? 0 : ab->second;
      const int nba = ba == directed.end() ? 0 : ba->second;
      if (nab != nba) ++r.inconsistent_edges;
    }
  }
  for (int v : boundary_vertices)
    if (find(v) == v) ++r.boundary_loops;
  if (!lengths.empty()) {
    r.edge_min = *std::min_element(lengths.begin(), lengths.end());
    r.edge_max = *std::max_element(lengths.begin(), lengths.end());
    r.edge_mean = std::accumulate(lengths.begin(), lengths.end(), 0.0) / lengths.size();
    r.edge_p05 = Percentile(lengths, 0.05);
    r.edge_p95 = Percentile(lengths, 0.95);
  }
}

}  // namespace

MeshReport InspectMesh(const TriMesh& mesh) {
  MeshReport r;
  r.vertices = mesh.NumVertices();
  r.faces = mesh.NumFaces();
  for (int i = 0; i < r.vertices; ++i)
    if (!mesh.V.row(i).allFinite()) r.nonfinite_vertices.push_back(i);
  std::vector<int> good_faces;
  const TriMesh good = ValidFaces(mesh, r, &good_faces);
  InspectFaces(good, good_faces, r);
  r.components = good.NumFaces() ? ConnectedComponents(good) : 0;
  InspectEdges(good, r);
  if (r.vertices > 0 && r.nonfinite_vertices.empty()) {
    r.bounds_min = mesh.V.colwise().minCoeff().transpose();
    r.bounds_max = mesh.V.colwise().maxCoeff().transpose();
  }
  return r;
}

double DistanceToSurface(const TriMesh& mesh, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (int f = 0; f < mesh.NumFaces(); ++f) {
    const Vec3 q =
        ClosestPointOnTriangle(p, mesh.V.row(mesh.F(f, 0)), mesh.V.row(mesh.F(f, 1)), mesh.V.row(mesh.F(f, 2)));
    best = std::min(best, (q - p).norm());
  }
  return best;
}

std::vector<std::string> CheckGarment(const Garment& g, const std::string& where, const ValidationOptions& options) {
  std::vector<std::string> out;
  auto add = [&](const std::string& s) { out.push_back(where + ": " + s); };
  const TriMesh& m = g.mesh;
  if (m.NumVertices() == 0) add("no vertices");
  if (m.NumFaces() == 0) {
    add("no triangles");
    return out;
  }
  const MeshReport r = InspectMesh(m);
  for (int v : r.nonfinite_vertices)
    add("vertex " + std::to_string(v) + " has a non-finite coordinate " + Fmt(m.V.row(v)));
  for (int f : r.bad_index_faces)
    add("face " + std::to_string(f) + " (" + std::to_string(m.F(f, 0)) + ", " + std::to_string(m.F(f, 1)) + ", " +
        std::to_string(m.F(f, 2)) + ") refers to a vertex " + "outside 0.." + std::to_string(m.NumVertices() - 1));
  if (!out.empty()) return out;  // the rest would only repeat these
  for (int f : r.degenerate_faces) {
    const Vec3 a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    std::ostringstream os;
    os << "face " << f << " (" << m.F(f, 0) << ", " << m.F(f, 1) << ", " << m.F(f, 2) << ") is degenerate (area "
       << 0.5 * (b - a).cross(c - a).norm() << " m²)";
    add(os.str());
  }
  for (const auto& e : r.nonmanifold_edges)
    add("edge (" + std::to_string(e[0]) + ", " + std::to_string(e[1]) +
        ") is shared by more than two faces (non-manifold)");
  if (options.require_oriented && r.inconsistent_edges > 0)
    add(std::to_string(r.inconsistent_edges) + " edges join faces of opposite winding");
  if (g.uv.rows() != 0 && g.uv.rows() != m.NumVertices())
    add("uv has " + std::to_string(g.uv.rows()) + " rows for " + std::to_string(m.NumVertices()) + " vertices");
  if (!g.layer.empty() && static_cast<int>(g.layer.size()) != m.NumVertices())
    add("layer has " + std::to_string(g.layer.size()) + " entries for " + std::to_string(m.NumVertices()) +
        " vertices");

  std::vector<char> used(m.NumVertices(), 0);
  for (int f = 0; f < m.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) used[m.F(f, k)] = 1;
  std::set<std::string> labels;
  for (const Anchor& a : g.anchors) {
    const std::string name = "anchor '" + a.label + "'";
    if (a.label.empty()) add("an anchor has an empty label");
    if (!labels.insert(a.label).second) add("duplicate anchor label '" + a.label + "'");
    if (a.vertex < 0 || a.vertex >= m.NumVertices()) {
      add(name + " names vertex " + std::to_string(a.vertex) + " but the mesh has " + std::to_string(m.NumVertices()) +
          " vertices");
      continue;
    }
    if (!used[a.vertex]) add(name + " names vertex " + std::to_string(a.vertex) + ", which is on no face");
    if (!a.position.allFinite()) {
      add(name + " has a non-finite position");
      continue;
    }
    const double d = DistanceToSurface(m, a.position);
    if (d > options.max_anchor_distance) {
      std::ostringstream os;
      os << name << " at " << Fmt(a.position) << " is " << d << " m from the surface (max "
         << options.max_anchor_distance << " m)";
      add(os.str());
    }
  }
  return out;
}

void ValidateGarment(const Garment& g, const std::string& where, const ValidationOptions& options) {
  const auto problems = CheckGarment(g, where, options);
  if (problems.empty()) return;
  std::string msg = problems.front();
  if (problems.size() > 1) msg += " (and " + std::to_string(problems.size() - 1) + " more problems)";
  throw Error(msg);
}

}  // namespace drape
