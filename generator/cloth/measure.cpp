#include "generator/cloth/measure.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "generator/cloth/collision.h"

namespace drape {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<P3>;

P3 Pt(const TriMesh& m, int v) { return P3(m.V(v, 0), m.V(v, 1), m.V(v, 2)); }

// Faces of a valid halfedge mesh in input order; false when one cannot be added
// (non-manifold edge or vertex, inconsistent orientation).
bool ToSurfaceMesh(const TriMesh& m, SurfaceMesh* sm) {
  std::vector<SurfaceMesh::Vertex_index> vi(m.NumVertices());
  for (int i = 0; i < m.NumVertices(); ++i) vi[i] = sm->add_vertex(Pt(m, i));
  for (int f = 0; f < m.NumFaces(); ++f)
    if (sm->add_face(vi[m.F(f, 0)], vi[m.F(f, 1)], vi[m.F(f, 2)]) == SurfaceMesh::null_face()) return false;
  return true;
}

// Exact test of one soup pair, as CGAL's self_intersections does for mesh faces:
// sharing an edge, they intersect only if coplanar and folded onto each other; sharing a
// vertex, if the edge opposite it in one meets the other triangle.
bool SoupPairIntersects(const TriMesh& m, int f, int g) {
  int shared = 0, sf[3], sg[3];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      if (m.F(f, a) == m.F(g, b)) {
        sf[shared] = a;
        sg[shared] = b;
        ++shared;
      }
  const K::Triangle_3 tf(Pt(m, m.F(f, 0)), Pt(m, m.F(f, 1)), Pt(m, m.F(f, 2)));
  const K::Triangle_3 tg(Pt(m, m.F(g, 0)), Pt(m, m.F(g, 1)), Pt(m, m.F(g, 2)));
  if (shared == 0) return CGAL::do_intersect(tf, tg);
  if (shared >= 3) return true;  // the same triangle twice
  if (shared == 2) {
    const int of = 3 - sf[0] - sf[1], og = 3 - sg[0] - sg[1];
    const P3 a = Pt(m, m.F(f, sf[0])), b = Pt(m, m.F(f, sf[1])), p = Pt(m, m.F(f, of)), q = Pt(m, m.F(g, og));
    return CGAL::coplanar(a, b, p, q) && CGAL::coplanar_orientation(a, b, p, q) == CGAL::POSITIVE;
  }
  const K::Segment_3 ef(Pt(m, m.F(f, (sf[0] + 1) % 3)), Pt(m, m.F(f, (sf[0] + 2) % 3)));
  const K::Segment_3 eg(Pt(m, m.F(g, (sg[0] + 1) % 3)), Pt(m, m.F(g, (sg[0] + 2) % 3)));
  return CGAL::do_intersect(ef, tg) || CGAL::do_intersect(eg, tf);
}

std::vector<std::array<int, 2>> SoupIntersections(const TriMesh& m, int* degenerate) {
  using Box =
      CGAL::Box_intersection_d::Box_with_handle_d<double, 3, const int*, CGAL::Box_intersection_d::ID_FROM_HANDLE>;
  std::vector<int> ids(m.NumFaces());
  std::vector<Box> boxes;
  for (int f = 0; f < m.NumFaces(); ++f) {
    ids[f] = f;
    const P3 a = Pt(m, m.F(f, 0)), b = Pt(m, m.F(f, 1)), c = Pt(m, m.F(f, 2));
    if (CGAL::collinear(a, b, c)) {
      ++*degenerate;
      continue;
    }
    boxes.emplace_back(a.bbox() + b.bbox() + c.bbox(), &ids[f]);
  }
  std::vector<std::array<int, 2>> out;
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), [&](const Box& x, const Box& y) {
    const int f = *x.handle(), g = *y.handle();
    if (SoupPairIntersects(m, f, g)) out.push_back({std::min(f, g), std::max(f, g)});
  });
  return out;
}

}  // namespace

std::vector<std::array<int, 2>> SelfIntersectingFacePairs(const TriMesh& mesh, bool* as_soup, int* degenerate_faces) {
  if (!mesh.V.allFinite()) throw Error("self-intersection test: the mesh has non-finite vertices");
  int degenerate = 0;
  std::vector<std::array<int, 2>> out;
  SurfaceMesh sm;
  const bool valid = ToSurfaceMesh(mesh, &sm);
  if (valid) {
    std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
    CGAL::Polygon_mesh_processing::self_intersections(sm, std::back_inserter(pairs));
    for (const auto& [a, b] : pairs) {
      const int f = static_cast<int>(a), g = static_cast<int>(b);
      if (f == g)
        ++degenerate;  // CGAL reports a zero-area face as (f, f)
      else
        out.push_back({std::min(f, g), std::max(f, g)});
    }
  } else {
    out = SoupIntersections(mesh, &degenerate);
  }
  std::sort(out.begin(), out.end());
  if (as_soup) *as_soup = !valid;
  if (degenerate_faces) *degenerate_faces = degenerate;
  return out;
}

EdgeStrain MeasureEdgeStrain(const Faces& F, const Points3& rest, const Points3& x) {
  DRAPE_CHECK(rest.rows() == x.rows(), "MeasureEdgeStrain: rest and x differ in size");
  TriMesh topo{rest, F};
  std::vector<double> s;
  for (const auto& e : UniqueEdges(topo)) {
    const double l0 = (rest.row(e[0]) - rest.row(e[1])).norm();
    if (l0 > 0) s.push_back((x.row(e[0]) - x.row(e[1])).norm() / l0 - 1);
  }
  EdgeStrain r;
  r.edges = static_cast<int>(s.size());
  if (s.empty()) return r;
  std::sort(s.begin(), s.end());
  auto rank = [&](double q) { return s[static_cast<size_t>(std::floor(q * (s.size() - 1)))]; };
  double sum = 0;
  for (double v : s) sum += v;
  r.mean = sum / s.size();
  r.median = rank(0.5);
  r.p99 = rank(0.99);
  r.max = s.back();
  r.min = s.front();
  return r;
}

ClothMeasurement MeasureCloth(const TriMesh& mesh, const Points3& rest) {
  ClothMeasurement m;
  m.intersecting_pairs =
      static_cast<int>(SelfIntersectingFacePairs(mesh, &m.measured_as_soup, &m.degenerate_faces).size());
  m.min_distance = MinimumNonAdjacentDistance(mesh.F, mesh.V);
  m.strain = MeasureEdgeStrain(mesh.F, rest, mesh.V);
  return m;
}

}  // namespace drape
