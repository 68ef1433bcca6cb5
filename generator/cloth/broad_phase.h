// Broad phase for cloth self-collision: the vertex–face (VF) and edge–edge (EE) pairs
// of one triangle mesh whose axis-aligned boxes overlap, pairs that share a vertex left
// out. A bounding-volume hierarchy over the faces is built once from a layout (the rest
// shape: cloth neighbourhoods stay neighbourhoods however it drapes) and refitted,
// not rebuilt, for every query.
//
// Each vertex and each edge is owned by its lowest-index face, and a vertex's (edge's)
// box lies inside the box of every face holding it, so every overlapping pair shows up
// in exactly one overlapping pair of face leaves: (owner, face) for VF, (owner, owner)
// for EE. No pair is emitted twice and nothing needs deduplicating; the lists are put
// in lexicographic order by a counting sort, so the result (and every computation that
// walks it) does not depend on the tree's shape.
// Faces that share a vertex always have overlapping boxes (both hold that vertex's
// box): the VF and EE pairs of those face pairs are listed once, at construction, and
// a search tests them from that list; the tree traversal skips such face pairs.
#pragma once

#include <array>
#include <vector>

#include "common/mesh.h"

namespace drape {

struct Aabb {
  Vec3 lo, hi;
  bool Overlaps(const Aabb& o) const {  // bitwise & on ints: no branch to mispredict in the hot loops
    return int(lo[0] <= o.hi[0]) & int(o.lo[0] <= hi[0]) & int(lo[1] <= o.hi[1]) & int(o.lo[1] <= hi[1]) &
           int(lo[2] <= o.hi[2]) & int(o.lo[2] <= hi[2]);
  }
  static Aabb Union(const Aabb& a, const Aabb& b) { return {a.lo.cwiseMin(b.lo), a.hi.cwiseMax(b.hi)}; }
};

struct CandidatePairs {
  std::vector<std::array<int, 2>> vf;  // (vertex, face), sorted
  std::vector<std::array<int, 2>> ee;  // (edge, edge), first < second, sorted
};

// Per-vertex boxes of the straight paths x0 → x1, each grown by pad (m) on every side.
void SweptVertexBoxes(const Points3& x0, const Points3& x1, double pad, std::vector<Aabb>* boxes);

// Per-axis median of x1 − x0: the motion most nodes share.
Vec3 MedianDisplacement(const Points3& x0, const Points3& x1);
// FindClose's boxes: paths x0 → x1 − MedianDisplacement, grown by dist/2 + slack.
void PathBoxes(const Points3& x0, const Points3& x1, double dist, double slack, std::vector<Aabb>* boxes);

class BroadPhase {
 public:
  // E: the mesh's edges (every one a side of some face of F); layout: positions the
  // tree is built from (any positions work; near ones make a tighter tree).
  BroadPhase(const Faces& F, const std::vector<std::array<int, 2>>& E, const Points3& layout);
  BroadPhase() = default;  // no mesh

  // Builds the tree anew from positions x (the refit tree of a layout far from x,
  // e.g. the flat rest shape of a crumpled garment, has boxes that overlap more).
  void Relayout(const Points3& x);

  // Superset reuse (margin > 0, m; 0: off): a tree search finds the pairs of the boxes
  // grown by `margin` and keeps them; a later query whose every box lies inside its
  // grown box takes its pairs from that superset by the same box tests, without a tree
  // search. The answer is the same (boxes that overlap overlap when grown; the filter
  // is the same exact test), only cheaper while the cloth moves less than the margin.
  // FindClose also keeps the superset while the boxes, carried by the rigid motion that
  // best fits x0 to the x0 of the last search, lie inside the grown boxes (a swinging
  // garment moves much more than it deforms).
  // Every kRebuildSearches-th search first rebuilds the tree around the grown boxes (the
  // tree's shape never changes an answer), so Relayout is not needed with reuse on.
  void SetReuseMargin(double margin);
  long long searches() const { return searches_; }  // tree searches run (work counter)

  // Every VF pair (v, f) with v not in f and every EE pair (a, b) with no shared vertex
  // whose boxes overlap (a face's or an edge's box: the union of its vertices' boxes).
  // vbox: one box per vertex (vertices in no face are tested too).
  void Find(const std::vector<Aabb>& vbox, CandidatePairs* out);

  // Every VF and EE pair (sharing no vertex) that could come within `dist` (m) of each
  // other at some t ∈ [0, 1] on the straight paths x0 → y1, for every y1 with
  // |y1_i − x1_i| ≤ slack (m) at each node: a superset, for corrections of x1 that stay
  // within slack: Find on the boxes of the paths with their common motion taken out
  // (PathBoxes).
  void FindClose(const Points3& x0, const Points3& x1, double dist, double slack, CandidatePairs* out);
  // FindClose on path boxes already made by PathBoxes(x0, x1, dist, slack, ...).
  void FindClosePaths(const std::vector<Aabb>& path_boxes, const Points3& x0, CandidatePairs* out);

  // The pairs of `from` (sorted, e.g. an earlier answer) whose boxes overlap for the
  // vertex boxes vbox, in from's order. When every box of vbox lies inside the vertex
  // box from was found for (BoxesInside), that is Find's answer for vbox: boxes inside
  // overlap only where the outer ones do. Same test, no tree or superset.
  void Filter(const std::vector<Aabb>& vbox, const CandidatePairs& from, CandidatePairs* out);

 private:
  // Leaves hold up to kLeafFaces faces: fewer nodes to refit and visit, the same pairs.
  static constexpr int kLeafFaces = 4;
  // Superset searches between two builds of the tree (refitted in between).
  static constexpr long long kRebuildSearches = 4;
  struct Node {
    Aabb box;
    int left = -1, right = -1;  // children; leaves: left = -1, right = first index in leaf_faces_
    int faces = 1;              // faces below
  };
  int Build(std::vector<int>& faces, int begin, int end, const std::vector<Vec3>& centroid);
  void BuildTree(const std::vector<Vec3>& centroid);
  void ListAdjacentPairs();                      // fverts_, adjacent_vf_, adjacent_ee_
  void SetBoxes(const std::vector<Aabb>& vbox);  // vbox_, ebox_, fbox_
  void Search(CandidatePairs* out);              // tree search on vbox_, ebox_, fbox_
  bool InsideGrown(const std::vector<Aabb>& vbox) const;
  // InsideGrown in the frame of the last search: the boxes mapped by the best rigid fit
  // of `points` onto the points of that search (FindClose's x0). Any map keeps boxes that
  // overlap overlapping (they share a point), so this only decides when to search again:
  // a garment swinging as a whole keeps its superset.
  bool InsideGrownMoved(const std::vector<Aabb>& vbox, const Points3& points) const;
  void Query(const std::vector<Aabb>& vbox, const Points3* points, CandidatePairs* out);  // Find; points: x0
  void FilterBoxes(const CandidatePairs& from, CandidatePairs* out) const;                // on vbox_, ebox_, fbox_
  void LeavesPair(const Node& a, const Node& b);
  void LeafPair(int fa, int fb);
  void QueryVertex(int v);

  Faces F_;
  std::vector<std::array<int, 2>> E_;
  int num_vertices_ = 0;
  std::vector<Node> nodes_;                   // nodes_[0]: the root; children after parents
  std::vector<int> leaf_faces_;               // the faces of every leaf, leaf after leaf
  std::vector<int> owned_start_v_, owned_v_;  // face → vertices it owns (CSR)
  std::vector<int> owned_start_e_, owned_e_;  // face → edges it owns (CSR)
  std::vector<int> orphan_vertices_;          // vertices in no face
  std::vector<std::array<int, 3>> fverts_;    // per face: its vertices
  // The VF and EE pairs LeafPair tests for the pairs of faces that share a vertex (boxes
  // that always overlap): tested from these lists, the search skips those face pairs.
  std::vector<std::array<int, 2>> adjacent_vf_, adjacent_ee_;
  std::vector<std::array<int, 3>> leaf_verts_;  // fverts_ in leaf_faces_ order
  // Per-query scratch (kept to avoid reallocations).
  std::vector<Aabb> vbox_, ebox_, fbox_;
  std::vector<Aabb> leaf_boxes_;  // fbox_ in leaf_faces_ order (Search)
  std::vector<Aabb> path_boxes_;
  std::vector<std::array<int, 2>> stack_, raw_vf_, raw_ee_, tmp_;
  size_t num_vf_ = 0, num_ee_ = 0;  // pairs found in raw_vf_, raw_ee_ (LeafPair)
  std::vector<int> count_;
  // Superset reuse.
  double reuse_margin_ = 0;  // m
  std::vector<Aabb> grown_;  // per vertex: the boxes the superset was found for
  CandidatePairs superset_;
  bool have_superset_ = false;
  Points3 search_points_;  // FindClose's x0 at the last search (empty: that search had none)
  long long searches_ = 0;
};

// True when every box of `inner` lies inside the box of the same index in `outer` (same size).
bool BoxesInside(const std::vector<Aabb>& inner, const std::vector<Aabb>& outer);

// The same pairs as Find (FindClose) by testing every VF and EE pair (O(n²)): the
// references for tests.
CandidatePairs BruteForceCandidates(const Faces& F, const std::vector<std::array<int, 2>>& E,
                                    const std::vector<Aabb>& vbox);
CandidatePairs BruteForceClose(const Faces& F, const std::vector<std::array<int, 2>>& E, const Points3& x0,
                               const Points3& x1, double dist, double slack);

}  // namespace drape
