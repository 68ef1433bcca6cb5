#include "garments/contour.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/error.h"
#include "common/format.h"
#include "garments/validate.h"

namespace drape {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Delaunay_mesh_vertex_base_2<K>;
using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;
using Criteria = CGAL::Delaunay_mesh_size_criteria_2<CDT>;
using Point = CDT::Point;
using VH = CDT::Vertex_handle;
using FH = CDT::Face_handle;

std::string Fmt(const Vec2& p) {
  std::ostringstream os;
  os << "(" << p.x() << ", " << p.y() << ")";
  return os.str();
}

double SignedArea(const std::vector<Vec2>& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec2& u = p[i];
    const Vec2& v = p[(i + 1) % p.size()];
    a += u.x() * v.y() - v.x() * u.y();
  }
  return 0.5 * a;
}

// Back edges: of a named opening, from its first corner to its last (exactly).
void CheckBackOpenings(Contour& out) {
  const size_t n = out.points.size();
  for (auto& [tag, poly] : out.back_openings) {
    size_t start = n;
    for (size_t i = 0; i < n && !tag.empty(); ++i)
      if (out.edge_tag[i] == tag && out.edge_tag[(i + n - 1) % n] != tag) start = i;
    if (start == n) throw Error("back_openings names '" + tag + "', which is not an opening of the contour");
    size_t end = start;
    while (out.edge_tag[end % n] == tag) ++end;
    const Vec2 first = out.points[start], last = out.points[end % n];
    if (poly.size() < 2) throw Error("the back edge of opening '" + tag + "' has fewer than 2 points");
    for (size_t i = 0; i < poly.size(); ++i)
      if (!poly[i].allFinite())
        throw Error("the back edge of opening '" + tag + "': point " + std::to_string(i) + " is not finite");
    if ((poly.front() - first).norm() > 1e-9 || (poly.back() - last).norm() > 1e-9)
      throw Error("the back edge of opening '" + tag + "' must run from " + Fmt(first) + " to " + Fmt(last) +
                  " (the opening's ends, in contour order); it runs from " + Fmt(poly.front()) + " to " +
                  Fmt(poly.back()));
    poly.front() = first;
    poly.back() = last;
    for (size_t i = 0; i + 1 < poly.size(); ++i)
      if ((poly[i] - poly[i + 1]).norm() < 1e-9)
        throw Error("the back edge of opening '" + tag + "': points " + std::to_string(i) + " and " +
                    std::to_string(i + 1) + " coincide at " + Fmt(poly[i]));
  }
}

// Checks the input polygon and returns it counter-clockwise with its edge tags.
Contour CheckedContour(const Contour& in) {
  const size_t n = in.points.size();
  if (n < 3) throw Error("contour has " + std::to_string(n) + " points (need at least 3)");
  if (!in.edge_tag.empty() && in.edge_tag.size() != n)
    throw Error("contour has " + std::to_string(n) + " points but " + std::to_string(in.edge_tag.size()) +
                " edge tags");
  for (size_t i = 0; i < n; ++i) {
    if (!in.points[i].allFinite()) throw Error("contour point " + std::to_string(i) + " is not finite");
  }
  for (size_t i = 0; i < n; ++i) {
    const size_t j = (i + 1) % n;
    if ((in.points[i] - in.points[j]).norm() < 1e-9)
      throw Error("contour points " + std::to_string(i) + " and " + std::to_string(j) + " coincide at " +
                  Fmt(in.points[i]));
  }
  // Brute-force simplicity test with exact predicates: any two non-adjacent edges
  // must not touch, adjacent edges must only share their common point.
  std::vector<K::Segment_2> seg(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec2 &a = in.points[i], &b = in.points[(i + 1) % n];
    seg[i] = K::Segment_2(Point(a.x(), a.y()), Point(b.x(), b.y()));
  }
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const bool adjacent = (j == i + 1) || (i == 0 && j == n - 1);
      if (!adjacent) {
        if (CGAL::do_intersect(seg[i], seg[j]))
          throw Error("contour is not simple: edge " + std::to_string(i) + " " + Fmt(in.points[i]) + " crosses edge " +
                      std::to_string(j) + " " + Fmt(in.points[j]));
      } else if (n == 3) {
        continue;
      } else {
        // Adjacent edges overlapping (a spike folding back on itself).
        const auto r = CGAL::intersection(seg[i], seg[j]);
        if (r && boost::get<K::Segment_2>(&*r))
          throw Error("contour folds back on itself at edges " + std::to_string(i) + " and " + std::to_string(j));
      }
    }
  }
  const double area = SignedArea(in.points);
  if (std::abs(area) < 1e-12) throw Error("contour has zero area");
  if (!in.edge_tag.empty()) {
    // Openings must be separated by seams (else two openings would merge into one
    // hole and, without any seam, the two layers would not be connected at all).
    bool any_seam = false;
    for (const auto& t : in.edge_tag) any_seam |= t.empty();
    if (!any_seam) throw Error("contour has no seam edge: front and back would not be connected");
    std::map<std::string, int> runs;
    for (size_t i = 0; i < n; ++i) {
      const std::string &t = in.edge_tag[i], &prev = in.edge_tag[(i + n - 1) % n];
      if (t.empty() || t == prev) continue;
      if (!prev.empty())
        throw Error("openings '" + prev + "' and '" + t + "' touch at contour point " + std::to_string(i) +
                    ": separate them by a seam edge");
      if (++runs[t] > 1)
        throw Error("opening '" + t + "' appears twice along the contour (again at edge " + std::to_string(i) + ")");
    }
  }
  Contour out = in;
  if (out.edge_tag.empty()) out.edge_tag.assign(n, "");
  if (area < 0) {
    // Reverse: new edge i runs p'[i] → p'[i+1] = old p[n-1-i] → p[n-2-i] = old edge n-2-i.
    std::reverse(out.points.begin(), out.points.end());
    for (size_t i = 0; i < n; ++i) out.edge_tag[i] = in.edge_tag.empty() ? "" : in.edge_tag[(2 * n - 2 - i) % n];
    for (auto& [tag, poly] : out.back_openings) std::reverse(poly.begin(), poly.end());
  }
  CheckBackOpenings(out);
  return out;
}

// Boundary samples: every contour corner is kept, each edge is split into
// ceil(len / h) equal segments; an opening gets at least two segments so that it
// has a vertex of its own on each layer (else front and back would share its edge).
struct Boundary {
  std::vector<Vec2> p;
  std::vector<std::string> tag;  // segment i: p[i] → p[i+1 mod n]
};

Boundary Resample(const Contour& c, double h) {
  const size_t n = c.points.size();
  std::vector<int> pieces(n);
  for (size_t i = 0; i < n; ++i) {
    const double len = (c.points[(i + 1) % n] - c.points[i]).norm();
    pieces[i] = std::max(1, static_cast<int>(std::ceil(len / h - 1e-9)));
  }
  // Runs of equal non-empty tags (CheckedContour guarantees at least one seam, so
  // every run has a start whose predecessor is a seam).
  for (size_t i = 0; i < n; ++i) {
    if (c.edge_tag[i].empty() || !c.edge_tag[(i + n - 1) % n].empty()) continue;
    int total = 0;
    for (size_t j = i; !c.edge_tag[j].empty(); j = (j + 1) % n) total += pieces[j];
    if (total < 2) pieces[i] = 2;
  }
  Boundary b;
  for (size_t i = 0; i < n; ++i) {
    const Vec2 a = c.points[i], e = c.points[(i + 1) % n];
    for (int k = 0; k < pieces[i]; ++k) {
      b.p.push_back(a + (e - a) * (static_cast<double>(k) / pieces[i]));
      b.tag.push_back(c.edge_tag[i]);
    }
  }
  return b;
}

double SegmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

bool InsidePolygon(const Vec2& p, const std::vector<Vec2>& poly) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 &a = poly[i], &b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

double DistanceToPolygon(const Vec2& p, const std::vector<Vec2>& poly) {
  double d = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < poly.size(); ++i) d = std::min(d, SegmentDistance(p, poly[i], poly[(i + 1) % poly.size()]));
  return d;
}

// A polyline (both ends kept) split into pieces about h long, at least two in all.
std::vector<Vec2> ResamplePolyline(const std::vector<Vec2>& p, double h) {
  std::vector<int> pieces(p.size() - 1);
  int total = 0;
  for (size_t i = 0; i + 1 < p.size(); ++i)
    total += pieces[i] = std::max(1, static_cast<int>(std::ceil((p[i + 1] - p[i]).norm() / h - 1e-9)));
  if (total < 2) pieces[0] = 2;
  std::vector<Vec2> out;
  for (size_t i = 0; i + 1 < p.size(); ++i)
    for (int k = 0; k < pieces[i]; ++k) out.push_back(p[i] + (p[i + 1] - p[i]) * (static_cast<double>(k) / pieces[i]));
  out.push_back(p.back());
  return out;
}

// A constraint of the triangulation: a piece of the outline or of an inner opening edge.
struct Segment {
  Vec2 a, b;
  bool seam = false;
};

// What is triangulated: the outline of both layers' patterns together (`outer`), the
// opening edges inside it (the front's, where the back's lies outside, or the back's),
// and each layer's own outline. Without back openings all three outlines are `front.p`.
struct Outline {
  Boundary front;                        // the front layer's outline, resampled
  std::vector<Vec2> back;                // the back layer's outline
  std::vector<Vec2> outer;               // the union's outline
  std::vector<std::vector<Vec2>> inner;  // opening edges inside `outer`, corner to corner
  std::vector<Segment> segments;         // outer's pieces in order, then inner's
  bool two = false;                      // the layers' outlines differ
};

Outline MakeOutline(const Contour& c, double h) {
  Outline o;
  o.front = Resample(c, h);
  const std::vector<Vec2>& p = o.front.p;
  const std::vector<std::string>& tag = o.front.tag;
  const size_t n = p.size();
  if (c.back_openings.empty()) {
    o.back = o.outer = p;
    for (size_t i = 0; i < n; ++i) o.segments.push_back({p[i], p[(i + 1) % n], tag[i].empty()});
    return o;
  }
  o.two = true;
  size_t s0 = 0;  // a seam piece: no opening runs across the walk's start
  while (!tag[s0].empty()) ++s0;
  std::vector<char> outer_seam;
  for (size_t k = 0; k < n;) {
    const size_t i = (s0 + k) % n;
    const auto it = c.back_openings.find(tag[i]);
    if (it == c.back_openings.end()) {
      o.outer.push_back(p[i]);
      o.back.push_back(p[i]);
      outer_seam.push_back(tag[i].empty() ? 1 : 0);
      ++k;
      continue;
    }
    std::vector<Vec2> front_edge;
    for (; k < n && tag[(s0 + k) % n] == it->first; ++k) front_edge.push_back(p[(s0 + k) % n]);
    front_edge.push_back(p[(s0 + k) % n]);
    const std::vector<Vec2> back_edge = ResamplePolyline(it->second, h);
    int outside = 0;
    for (size_t j = 1; j + 1 < back_edge.size(); ++j) outside += !InsidePolygon(back_edge[j], p);
    if (outside != 0 && outside != static_cast<int>(back_edge.size()) - 2)
      throw Error("the back edge of opening '" + it->first +
                  "' crosses its front edge (it must lie wholly outside the outline or wholly inside)");
    const std::vector<Vec2>& out_edge = outside ? back_edge : front_edge;
    o.inner.push_back(outside ? front_edge : back_edge);
    for (size_t j = 0; j + 1 < out_edge.size(); ++j) {
      o.outer.push_back(out_edge[j]);
      outer_seam.push_back(0);
    }
    for (size_t j = 0; j + 1 < back_edge.size(); ++j) o.back.push_back(back_edge[j]);
  }
  const size_t m = o.outer.size();
  for (size_t i = 0; i < m; ++i) o.segments.push_back({o.outer[i], o.outer[(i + 1) % m], outer_seam[i] != 0});
  for (const auto& e : o.inner)
    for (size_t j = 0; j + 1 < e.size(); ++j) o.segments.push_back({e[j], e[j + 1], false});
  // Nothing may cross: pieces sharing an end only touch there, the others not at all.
  const size_t ns = o.segments.size();
  std::vector<K::Segment_2> seg(ns);
  for (size_t i = 0; i < ns; ++i)
    seg[i] =
        K::Segment_2(Point(o.segments[i].a.x(), o.segments[i].a.y()), Point(o.segments[i].b.x(), o.segments[i].b.y()));
  for (size_t i = 0; i < ns; ++i) {
    const Segment& u = o.segments[i];
    for (size_t j = i + 1; j < ns; ++j) {
      const Segment& v = o.segments[j];
      const bool share = u.a == v.a || u.a == v.b || u.b == v.a || u.b == v.b;
      bool bad = false;
      if (!share) {
        bad = CGAL::do_intersect(seg[i], seg[j]);
      } else {
        const auto r = CGAL::intersection(seg[i], seg[j]);
        bad = r && boost::get<K::Segment_2>(&*r);
      }
      if (bad)
        throw Error("the outline with its back opening edges is not simple: " + Fmt(u.a) + "-" + Fmt(u.b) +
                    " crosses " + Fmt(v.a) + "-" + Fmt(v.b));
    }
  }
  return o;
}

// Marks faces inside the outline (reached from the infinite face across at least one
// constraint: inner opening edges divide the inside, they do not make holes); CGAL's
// own marks are not kept up to date by every operation (Lloyd moves vertices).
void MarkDomain(CDT& cdt) {
  for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->set_in_domain(false);
  std::map<FH, int> level;
  std::deque<std::pair<FH, int>> border{{cdt.infinite_face(), 0}};
  while (!border.empty()) {
    auto [start, lev] = border.front();
    border.pop_front();
    if (level.count(start)) continue;
    std::deque<FH> queue{start};
    level[start] = lev;
    while (!queue.empty()) {
      FH f = queue.front();
      queue.pop_front();
      for (int i = 0; i < 3; ++i) {
        FH g = f->neighbor(i);
        if (level.count(g)) continue;
        if (cdt.is_constrained(CDT::Edge(f, i))) {
          border.push_back({g, lev + 1});
        } else {
          level[g] = lev;
          queue.push_back(g);
        }
      }
    }
  }
  for (auto& [f, lev] : level)
    if (!cdt.is_infinite(f)) f->set_in_domain(lev >= 1);
}

Vec2 ToVec(const Point& p) { return Vec2(CGAL::to_double(p.x()), CGAL::to_double(p.y())); }

// Per CDT vertex: is it on a seam (stitched) and/or on an opening.
struct VertexClass {
  bool seam = false;
  bool opening = false;
};

std::map<VH, VertexClass> ClassifyBoundary(const CDT& cdt, const Outline& o) {
  std::map<VH, VertexClass> cls;
  const size_t n = o.segments.size();
  for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e) {
    if (!cdt.is_constrained(*e)) continue;
    VH u = e->first->vertex(CDT::cw(e->second)), v = e->first->vertex(CDT::ccw(e->second));
    const Vec2 mid = 0.5 * (ToVec(u->point()) + ToVec(v->point()));
    size_t best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < n; ++i) {
      const double d = SegmentDistance(mid, o.segments[i].a, o.segments[i].b);
      if (d < best_d) best_d = d, best = i;
    }
    const bool seam = o.segments[best].seam;
    for (VH w : {u, v}) {
      auto& c = cls[w];
      (seam ? c.seam : c.opening) = true;
    }
  }
  return cls;
}

// Which layers a face of the triangulation belongs to.
struct FaceLayers {
  bool front = false, back = false;
  bool Both() const { return front && back; }
};

FaceLayers LayersOf(const CDT& cdt, FH f, const Outline& o) {
  if (cdt.is_infinite(f) || !f->is_in_domain()) return {};
  if (!o.two) return {true, true};
  const Vec2 c = (ToVec(f->vertex(0)->point()) + ToVec(f->vertex(1)->point()) + ToVec(f->vertex(2)->point())) / 3.0;
  return {InsidePolygon(c, o.front.p), InsidePolygon(c, o.back)};
}

// Lloyd-style smoothing: each interior vertex moves to the area-weighted mean of its
// incident triangles' centroids, then the constrained Delaunay triangulation is
// rebuilt. Written here instead of CGAL::lloyd_optimize_mesh_2 because that one
// orders its work by handle address and so differs from run to run; here points are
// inserted in lexicographic order, which makes the result reproducible bit for bit.
CDT Smooth(const CDT& start, const Outline& o, int iterations, double h) {
  CDT cdt = start;
  MarkDomain(cdt);
  for (int it = 0; it < iterations; ++it) {
    std::vector<std::pair<Vec2, bool>> pts;  // position, fixed
    std::map<VH, int> index;
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
      index[v] = static_cast<int>(pts.size());
      pts.push_back({ToVec(v->point()), cdt.are_there_incident_constraints(v)});
    }
    std::vector<Vec2> sum(pts.size(), Vec2::Zero());
    std::vector<double> weight(pts.size(), 0);
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
      if (!f->is_in_domain()) continue;
      const Vec2 a = ToVec(f->vertex(0)->point()), c1 = ToVec(f->vertex(1)->point()), c2 = ToVec(f->vertex(2)->point());
      const double area = 0.5 * std::abs((c1 - a).x() * (c2 - a).y() - (c1 - a).y() * (c2 - a).x());
      const Vec2 centroid = (a + c1 + c2) / 3.0;
      for (int k = 0; k < 3; ++k) {
        const int i = index[f->vertex(k)];
        sum[i] += area * centroid;
        weight[i] += area;
      }
    }
    std::vector<std::array<Vec2, 2>> constraints;
    for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e) {
      if (!cdt.is_constrained(*e)) continue;
      Vec2 u = ToVec(e->first->vertex(CDT::cw(e->second))->point());
      Vec2 v = ToVec(e->first->vertex(CDT::ccw(e->second))->point());
      if (std::make_pair(v.x(), v.y()) < std::make_pair(u.x(), u.y())) std::swap(u, v);
      constraints.push_back({u, v});
    }
    std::vector<Vec2> moved;
    moved.reserve(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) {
      Vec2 p = pts[i].first;
      if (!pts[i].second && weight[i] > 0) {
        const Vec2 q = sum[i] / weight[i];
        // Keep points inside and off the outline (else the rebuild could lose them).
        bool off_inner = true;
        for (const auto& e : o.inner)
          for (size_t j = 0; j + 1 < e.size(); ++j) off_inner &= SegmentDistance(q, e[j], e[j + 1]) > 0.25 * h;
        if (InsidePolygon(q, o.outer) && DistanceToPolygon(q, o.outer) > 0.25 * h && off_inner) p = q;
      }
      moved.push_back(p);
    }
    auto lex = [](const Vec2& a, const Vec2& c) { return std::make_pair(a.x(), a.y()) < std::make_pair(c.x(), c.y()); };
    std::sort(moved.begin(), moved.end(), lex);
    std::sort(constraints.begin(), constraints.end(), [&](const auto& a, const auto& c) {
      if (lex(a[0], c[0])) return true;
      if (lex(c[0], a[0])) return false;
      return lex(a[1], c[1]);
    });
    CDT next;
    std::map<std::pair<double, double>, VH> handle;
    for (const Vec2& p : moved) handle[{p.x(), p.y()}] = next.insert(Point(p.x(), p.y()));
    for (const auto& c : constraints)
      next.insert_constraint(handle.at({c[0].x(), c[0].y()}), handle.at({c[1].x(), c[1].y()}));
    MarkDomain(next);
    cdt = std::move(next);
  }
  return cdt;
}

// Constrained Delaunay triangulation of the outline, refined to the edge length and
// Lloyd-smoothed (then refined again: smoothing can leave a few triangles below the
// angle bound).
CDT TriangulateOutline(const Outline& outline, const ContourOptions& options, const Criteria& criteria) {
  CDT cdt;
  std::vector<VH> bv;
  bv.reserve(outline.outer.size());
  for (const Vec2& p : outline.outer) bv.push_back(cdt.insert(Point(p.x(), p.y())));
  for (size_t i = 0; i < bv.size(); ++i) cdt.insert_constraint(bv[i], bv[(i + 1) % bv.size()]);
  for (const auto& e : outline.inner) {
    std::vector<VH> ev;
    ev.reserve(e.size());
    for (const Vec2& p : e) ev.push_back(cdt.insert(Point(p.x(), p.y())));
    for (size_t i = 0; i + 1 < ev.size(); ++i) cdt.insert_constraint(ev[i], ev[i + 1]);
  }
  CGAL::refine_Delaunay_mesh_2(cdt, criteria);
  MarkDomain(cdt);
  if (options.lloyd_iterations > 0) {
    cdt = Smooth(cdt, outline, options.lloyd_iterations, options.edge_length);
    CGAL::refine_Delaunay_mesh_2(cdt, criteria);
    MarkDomain(cdt);
  }
  return cdt;
}

// An interior edge joining two stitched vertices would exist on both layers at the
// same place (non-manifold) where both layers have it: split it and refine again until
// there is none. Returns the rounds taken; `cls` is the final boundary classification.
int SplitSeamChords(CDT& cdt, const Outline& outline, const Criteria& criteria, double h,
                    std::map<VH, VertexClass>& cls) {
  for (int rounds = 0;; ++rounds) {
    cls = ClassifyBoundary(cdt, outline);
    std::vector<Point> splits;
    for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e) {
      if (cdt.is_constrained(*e)) continue;
      FH f = e->first, g = f->neighbor(e->second);
      if (!LayersOf(cdt, f, outline).Both() && !LayersOf(cdt, g, outline).Both()) continue;
      VH u = f->vertex(CDT::cw(e->second)), v = f->vertex(CDT::ccw(e->second));
      auto iu = cls.find(u), iv = cls.find(v);
      if (iu != cls.end() && iv != cls.end() && iu->second.seam && iv->second.seam)
        splits.push_back(CGAL::midpoint(u->point(), v->point()));
    }
    if (splits.empty()) return rounds;
    if (rounds >= 40) {
      std::ostringstream os;
      os << "the outline is too narrow near " << Fmt(ToVec(splits.front())) << " for edge_length " << h
         << " m (front and back would touch there): use a smaller edge_length or widen the outline";
      throw Error(os.str());
    }
    for (const Point& p : splits) cdt.insert(p);
    // Refinement first (quality), but in a sharp spike it keeps adding boundary points
    // that make new chords: after a few rounds only the splitting points are inserted.
    if (rounds < 3) CGAL::refine_Delaunay_mesh_2(cdt, criteria);
    MarkDomain(cdt);
  }
}

// The two layers' connectivity: the front numbered by first appearance in the face list
// (so that importers which renumber that way, e.g. assimp's OBJ reader, keep the order),
// the back with reversed winding and its own copies numbered by first appearance in
// its faces, stitched (seam) vertices shared. Without back openings the back is the
// front's mirror.
struct Layers {
  std::vector<VH> front_vertices, back_vertices;  // back_vertices[j] is vertex #front + j
  std::vector<std::array<int, 3>> front_faces, back_faces;
  std::vector<char> seam;  // per front vertex
  int num_vertices = 0;
};

Layers NumberLayers(const CDT& cdt, const std::map<VH, VertexClass>& cls, const Outline& outline) {
  Layers l;
  std::map<VH, int> front_index;
  std::vector<FH> back;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    const FaceLayers in = LayersOf(cdt, f, outline);
    if (in.back) back.push_back(f);
    if (!in.front) continue;
    std::array<int, 3> tri;
    for (int k = 0; k < 3; ++k) {
      VH v = f->vertex(k);
      auto [it, inserted] = front_index.emplace(v, static_cast<int>(l.front_vertices.size()));
      if (inserted) l.front_vertices.push_back(v);
      tri[k] = it->second;
    }
    l.front_faces.push_back(tri);
  }
  DRAPE_CHECK(!l.front_faces.empty(), "empty triangulation");
  const int nf = static_cast<int>(l.front_vertices.size());
  l.seam.assign(nf, 0);
  for (int i = 0; i < nf; ++i) {
    auto it = cls.find(l.front_vertices[i]);
    l.seam[i] = it != cls.end() && it->second.seam ? 1 : 0;
  }
  std::map<VH, int> back_index;
  int next = nf;
  for (FH f : back) {
    std::array<int, 3> b;
    const std::array<VH, 3> rev = {f->vertex(0), f->vertex(2), f->vertex(1)};
    for (int k = 0; k < 3; ++k) {
      const VH v = rev[k];
      const auto c = cls.find(v);
      if (c != cls.end() && c->second.seam) {
        const auto fi = front_index.find(v);
        DRAPE_CHECK(fi != front_index.end(), "a stitched vertex on the back layer only");
        b[k] = fi->second;
      } else {
        auto [it, inserted] = back_index.emplace(v, next);
        if (inserted) {
          l.back_vertices.push_back(v);
          ++next;
        }
        b[k] = it->second;
      }
    }
    l.back_faces.push_back(b);
  }
  l.num_vertices = next;
  return l;
}

// Vertices on the pattern (uv) and in 3D: the front layer at +gap/2, the back at -gap/2,
// stitched vertices at 0; front faces first.
void FillTwoLayers(const Layers& l, double layer_gap, Garment& g) {
  const int nv = l.num_vertices, nf = static_cast<int>(l.front_vertices.size());
  g.mesh.V.resize(nv, 3);
  g.uv.resize(nv, 2);
  g.layer.assign(nv, 0);
  const double half = 0.5 * layer_gap;
  for (int i = 0; i < nf; ++i) {
    const Vec2 p = ToVec(l.front_vertices[i]->point());
    g.uv.row(i) = p;
    g.mesh.V.row(i) = Vec3(p.x(), p.y(), l.seam[i] ? 0.0 : half);
  }
  for (size_t j = 0; j < l.back_vertices.size(); ++j) {
    const int i = nf + static_cast<int>(j);
    const Vec2 p = ToVec(l.back_vertices[j]->point());
    g.uv.row(i) = p;
    g.mesh.V.row(i) = Vec3(p.x(), p.y(), -half);
    g.layer[i] = 1;
  }
  g.mesh.F.resize(static_cast<int>(l.front_faces.size() + l.back_faces.size()), 3);
  int r = 0;
  for (const auto& t : l.front_faces) g.mesh.F.row(r++) << t[0], t[1], t[2];
  for (const auto& t : l.back_faces) g.mesh.F.row(r++) << t[0], t[1], t[2];
}

// Anchors: nearest front-layer vertex on the pattern (lowest index on ties).
void PlaceAnchors(const std::vector<AnchorSpec>& anchors, Garment& g) {
  const int nv = g.mesh.NumVertices();
  for (const AnchorSpec& spec : anchors) {
    int best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (int i = 0; i < nv; ++i) {
      if (g.layer[i] != 0) continue;
      const double d = (Vec2(g.uv.row(i)) - spec.uv).squaredNorm();
      if (d < best_d) best_d = d, best = i;
    }
    Anchor a;
    a.label = spec.label;
    a.uv = spec.uv;
    a.vertex = best;
    a.position = g.mesh.V.row(best);
    g.anchors.push_back(a);
  }
}

MeshStats ContourMeshStats(const Contour& contour, const Layers& l, const Garment& g, int rounds, double h) {
  const int nf = static_cast<int>(l.front_vertices.size());
  MeshStats s;
  s.vertices = l.num_vertices;
  s.faces = g.mesh.NumFaces();
  s.front_vertices = nf;
  s.seam_vertices = static_cast<int>(std::count(l.seam.begin(), l.seam.end(), 1));
  s.refine_rounds = rounds;
  // Openings = runs of equal non-empty tags around the contour.
  const size_t n = contour.edge_tag.size();
  for (size_t i = 0; i < n; ++i)
    if (!contour.edge_tag[i].empty() && contour.edge_tag[(i + n - 1) % n].empty()) ++s.openings;
  // Pattern edge lengths and angles of the front triangulation.
  TriMesh flat;
  flat.V.resize(nf, 3);
  for (int i = 0; i < nf; ++i) flat.V.row(i) = Vec3(g.uv(i, 0), g.uv(i, 1), 0.0);
  flat.F = g.mesh.F.topRows(static_cast<int>(l.front_faces.size()));
  const MeshReport rep = InspectMesh(flat);
  s.edge_min = rep.edge_min;
  s.edge_mean = rep.edge_mean;
  s.edge_max = rep.edge_max;
  s.ratio_min = rep.edge_min / h;
  s.ratio_p05 = rep.edge_p05 / h;
  s.ratio_p95 = rep.edge_p95 / h;
  s.ratio_max = rep.edge_max / h;
  s.min_angle_deg = rep.min_angle_deg;
  s.area = rep.area;
  s.boundary_loops = InspectMesh(g.mesh).boundary_loops;
  return s;
}

}  // namespace

void ContourOptions::Validate() const {
  if (!(edge_length >= 0.002 && edge_length <= 1.0))
    throw Error("edge_length must be in [0.002, 1] m, got " + FormatNumber(edge_length));
  if (!(layer_gap >= 0 && layer_gap <= 0.1))
    throw Error("layer_gap must be in [0, 0.1] m, got " + FormatNumber(layer_gap));
  if (!(angle_bound > 0 && angle_bound <= 0.125))
    throw Error("angle_bound must be in (0, 0.125], got " + FormatNumber(angle_bound));
  if (!(size_factor >= 0.5 && size_factor <= 4))
    throw Error("size_factor must be in [0.5, 4], got " + FormatNumber(size_factor));
  if (lloyd_iterations < 0 || lloyd_iterations > 1000)
    throw Error("lloyd_iterations must be in [0, 1000], got " + std::to_string(lloyd_iterations));
}

void MaskOptions::Validate() const {
  if (!(metres_per_pixel > 0 && std::isfinite(metres_per_pixel))) throw Error("metres_per_pixel must be > 0");
  if (!(simplify_px >= 0)) throw Error("simplify_px must be >= 0");
}

Garment GarmentFromContour(const Contour& contour_in, const std::vector<AnchorSpec>& anchors,
                           const ContourOptions& options, const std::string& category, const std::string& instance,
                           MeshStats* stats_out) {
  options.Validate();
  const Contour contour = CheckedContour(contour_in);
  const double h = options.edge_length;
  const Outline outline = MakeOutline(contour, h);
  const Criteria criteria(options.angle_bound, options.size_factor * h);
  CDT cdt = TriangulateOutline(outline, options, criteria);
  std::map<VH, VertexClass> cls;
  const int rounds = SplitSeamChords(cdt, outline, criteria, h, cls);
  const Layers layers = NumberLayers(cdt, cls, outline);

  Garment g;
  g.category = category;
  g.instance = instance;
  FillTwoLayers(layers, options.layer_gap, g);
  PlaceAnchors(anchors, g);
  if (stats_out) *stats_out = ContourMeshStats(contour, layers, g, rounds, h);
  return g;
}

Contour ContourFromMask(const cv::Mat& mask, const MaskOptions& options) {
  options.Validate();
  if (mask.empty()) throw Error("mask is empty");
  if (mask.type() != CV_8UC1)
    throw Error("mask must be 8-bit single channel (CV_8UC1), got type " + std::to_string(mask.type()));
  cv::Mat bin = mask != 0;
  // A one-pixel frame so that blobs touching the border still get closed contours.
  cv::Mat padded;
  cv::copyMakeBorder(bin, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(padded, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) throw Error("mask has no foreground pixels");
  size_t best = 0;
  double best_area = -1;
  for (size_t i = 0; i < contours.size(); ++i) {
    const double a = std::abs(cv::contourArea(contours[i]));
    if (a > best_area) best_area = a, best = i;
  }
  std::vector<cv::Point> poly = contours[best];
  if (options.simplify_px > 0) {
    std::vector<cv::Point> simple;
    cv::approxPolyDP(poly, simple, options.simplify_px, true);
    poly = simple;
  }
  if (poly.size() < 3 || best_area <= 0)
    throw Error("mask's largest blob (" + std::to_string(contours[best].size()) +
                " contour pixels) is too thin to mesh");
  Contour c;
  const double m = options.metres_per_pixel;
  for (const cv::Point& q : poly) {
    const int col = q.x - 1, row = q.y - 1;  // undo the padding
    c.points.emplace_back((col + 0.5) * m, (mask.rows - row - 0.5) * m);
  }
  c.edge_tag.assign(c.points.size(), "");
  return c;
}

}  // namespace drape
