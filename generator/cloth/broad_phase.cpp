#include "generator/cloth/broad_phase.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "common/error.h"

namespace drape {
namespace {

bool FaceHas(const Faces& F, int f, int v) { return F(f, 0) == v || F(f, 1) == v || F(f, 2) == v; }
bool Has(const std::array<int, 3>& f, int v) { return int(f[0] == v) | int(f[1] == v) | int(f[2] == v); }
// Whether two faces share a vertex (branch-free).
bool ShareVertex(const std::array<int, 3>& a, const std::array<int, 3>& b) {
  return int(Has(b, a[0])) | int(Has(b, a[1])) | int(Has(b, a[2]));
}
bool EdgesShare(const std::array<int, 2>& a, const std::array<int, 2>& b) {
  return int(a[0] == b[0]) | int(a[0] == b[1]) | int(a[1] == b[0]) | int(a[1] == b[1]);
}

// Lexicographic order of pairs with entries in [0, n): two stable counting passes
// (by second, then by first), O(size + n).
void SortPairs(std::vector<std::array<int, 2>>& v, int n, std::vector<std::array<int, 2>>& tmp,
               std::vector<int>& count) {
  tmp.resize(v.size());
  for (int key : {1, 0}) {
    count.assign(static_cast<size_t>(n) + 1, 0);
    for (const auto& p : v) ++count[p[key] + 1];
    for (int i = 0; i < n; ++i) count[i + 1] += count[i];
    for (const auto& p : v) tmp[count[p[key]]++] = p;
    v.swap(tmp);
  }
}

}  // namespace

void SweptVertexBoxes(const Points3& x0, const Points3& x1, double pad, std::vector<Aabb>* boxes) {
  boxes->resize(static_cast<size_t>(x0.rows()));
  for (Eigen::Index i = 0; i < x0.rows(); ++i) {
    Aabb& b = (*boxes)[i];
    for (int a = 0; a < 3; ++a) {
      const double p = x0(i, a), q = x1(i, a);
      b.lo[a] = std::min(p, q) - pad;
      b.hi[a] = std::max(p, q) + pad;
    }
  }
}

namespace {

// The k-th smallest of d (what nth_element puts at k; d is reordered). A strided sample
// brackets it: one branch-free pass counts the values below the bracket and gathers
// those inside into buf, and nth_element runs on those few; when the bracket misses k,
// on all of d. Either way the answer is the k-th smallest value.
double KthSmallest(std::vector<double>& d, size_t k, std::vector<double>& buf) {
  const size_t n = d.size();
  constexpr int kSample = 63, kReach = 8;  // bracket: sample ranks q ± kReach
  if (n >= 4 * size_t{kSample}) {
    std::array<double, kSample> sample;
    for (int s = 0; s < kSample; ++s) sample[s] = d[(2 * static_cast<size_t>(s) + 1) * n / (2 * size_t{kSample})];
    std::sort(sample.begin(), sample.end());
    const int q = static_cast<int>(static_cast<double>(k) / static_cast<double>(n) * kSample);
    const double lo = sample[std::max(0, q - kReach)], hi = sample[std::min(kSample - 1, q + kReach)];
    buf.resize(n);
    size_t below = 0, m = 0;
    for (size_t i = 0; i < n; ++i) {
      const double v = d[i];
      buf[m] = v;
      m += (v >= lo) & (v <= hi);
      below += v < lo;
    }
    if (below <= k && k < below + m) {
      std::nth_element(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(k - below), buf.begin() + m);
      return buf[k - below];
    }
  }
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(k), d.end());
  return d[k];
}

}  // namespace

Vec3 MedianDisplacement(const Points3& x0, const Points3& x1) {
  Vec3 out = Vec3::Zero();
  const Eigen::Index n = x0.rows();
  if (n == 0) return out;
  std::vector<double> d(static_cast<size_t>(n)), buf;
  for (int k = 0; k < 3; ++k) {
    for (Eigen::Index i = 0; i < n; ++i) d[i] = x1(i, k) - x0(i, k);
    out[k] = KthSmallest(d, static_cast<size_t>(n / 2), buf);
  }
  return out;
}

// Translating every path by the same t·s changes no pairwise distance at any t, so the
// boxes may leave out the motion most nodes share (a falling garment's boxes then hold
// its deformation, not its fall).
void PathBoxes(const Points3& x0, const Points3& x1, double dist, double slack, std::vector<Aabb>* boxes) {
  const Vec3 s = MedianDisplacement(x0, x1);
  const double pad = 0.5 * dist + slack;
  boxes->resize(static_cast<size_t>(x0.rows()));
  for (Eigen::Index i = 0; i < x0.rows(); ++i) {
    Aabb& b = (*boxes)[i];
    for (int a = 0; a < 3; ++a) {
      const double p = x0(i, a), q = x1(i, a) - s[a];
      b.lo[a] = std::min(p, q) - pad;
      b.hi[a] = std::max(p, q) + pad;
    }
  }
}

BroadPhase::BroadPhase(const Faces& F, const std::vector<std::array<int, 2>>& E, const Points3& layout)
    : F_(F), E_(E), num_vertices_(static_cast<int>(layout.rows())) {
  const int nf = static_cast<int>(F.rows()), ne = static_cast<int>(E.size());
  // Owners: the lowest-index face holding each vertex and each edge.
  std::vector<int> vowner(num_vertices_, -1), eowner(ne, -1);
  for (int f = nf - 1; f >= 0; --f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      if (a < 0 || a >= num_vertices_)
        throw Error("broad phase: face " + std::to_string(f) + " has an index out of range");
      vowner[a] = f;
      const std::array<int, 2> key{std::min(a, b), std::max(a, b)};
      const auto it = std::lower_bound(E.begin(), E.end(), key);
      if (it != E.end() && *it == key) eowner[it - E.begin()] = f;
    }
  for (int e = 0; e < ne; ++e)
    if (eowner[e] < 0)
      throw Error("broad phase: edge " + std::to_string(e) + " (" + std::to_string(E[e][0]) + ", " +
                  std::to_string(E[e][1]) + ") is no side of a face (edges must be sorted and unique)");
  auto csr = [nf](const std::vector<int>& owner, std::vector<int>& start, std::vector<int>& items) {
    start.assign(static_cast<size_t>(nf) + 1, 0);
    for (int o : owner)
      if (o >= 0) ++start[o + 1];
    for (int f = 0; f < nf; ++f) start[f + 1] += start[f];
    items.resize(start[nf]);
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int i = 0; i < static_cast<int>(owner.size()); ++i)
      if (owner[i] >= 0) items[fill[owner[i]]++] = i;
  };
  csr(vowner, owned_start_v_, owned_v_);
  csr(eowner, owned_start_e_, owned_e_);
  for (int v = 0; v < num_vertices_; ++v)
    if (vowner[v] < 0) orphan_vertices_.push_back(v);
  ListAdjacentPairs();
  Relayout(layout);
}

// The pairs of faces sharing a vertex (their boxes always overlap: both hold that
// vertex's box) and every VF and EE pair LeafPair would test for them, sorted.
void BroadPhase::ListAdjacentPairs() {
  const Faces& F = F_;
  const auto& E = E_;
  const int nf = static_cast<int>(F.rows());
  fverts_.resize(nf);
  for (int f = 0; f < nf; ++f) fverts_[f] = {F(f, 0), F(f, 1), F(f, 2)};
  std::vector<int> start(static_cast<size_t>(num_vertices_) + 1, 0), faces_of(3 * static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) ++start[F(f, k) + 1];
  for (int v = 0; v < num_vertices_; ++v) start[v + 1] += start[v];
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) faces_of[fill[F(f, k)]++] = f;
  }
  std::vector<int> adjacent;
  for (int fa = 0; fa < nf; ++fa) {
    adjacent.clear();
    for (int k = 0; k < 3; ++k)
      for (int i = start[F(fa, k)]; i < start[F(fa, k) + 1]; ++i)
        if (faces_of[i] > fa) adjacent.push_back(faces_of[i]);
    std::sort(adjacent.begin(), adjacent.end());
    adjacent.erase(std::unique(adjacent.begin(), adjacent.end()), adjacent.end());
    for (const int fb : adjacent) {
      for (int side = 0; side < 2; ++side) {
        const int owner = side ? fb : fa, f = side ? fa : fb;
        for (int k = owned_start_v_[owner]; k < owned_start_v_[owner + 1]; ++k)
          if (!FaceHas(F, f, owned_v_[k])) adjacent_vf_.push_back({owned_v_[k], f});
      }
      for (int i = owned_start_e_[fa]; i < owned_start_e_[fa + 1]; ++i)
        for (int j = owned_start_e_[fb]; j < owned_start_e_[fb + 1]; ++j) {
          const int a = owned_e_[i], b = owned_e_[j];
          if (!EdgesShare(E[a], E[b])) adjacent_ee_.push_back({std::min(a, b), std::max(a, b)});
        }
    }
  }
  std::sort(adjacent_vf_.begin(), adjacent_vf_.end());
  std::sort(adjacent_ee_.begin(), adjacent_ee_.end());
}

void BroadPhase::Relayout(const Points3& layout) {
  const int nf = static_cast<int>(F_.rows());
  if (layout.rows() != num_vertices_)
    throw Error("broad phase: a layout of " + std::to_string(layout.rows()) + " positions for " +
                std::to_string(num_vertices_) + " vertices");
  const Faces& F = F_;
  std::vector<Vec3> centroid(nf);
  for (int f = 0; f < nf; ++f)
    centroid[f] = (layout.row(F(f, 0)) + layout.row(F(f, 1)) + layout.row(F(f, 2))).transpose() / 3.0;
  BuildTree(centroid);
}

void BroadPhase::BuildTree(const std::vector<Vec3>& centroid) {
  const int nf = static_cast<int>(F_.rows());
  nodes_.clear();
  if (nf == 0) return;
  std::vector<int> faces(nf);
  for (int f = 0; f < nf; ++f) faces[f] = f;
  nodes_.reserve(2 * static_cast<size_t>(nf));
  Build(faces, 0, nf, centroid);
  leaf_faces_ = std::move(faces);
  leaf_verts_.resize(nf);
  for (int k = 0; k < nf; ++k) leaf_verts_[k] = fverts_[leaf_faces_[k]];
}

void BroadPhase::SetReuseMargin(double margin) {
  if (!(margin >= 0 && std::isfinite(margin))) throw Error("broad phase: reuse margin must be finite and >= 0 m");
  reuse_margin_ = margin;
  have_superset_ = false;
}

// Top-down median split along the centroids' widest axis (ties by face index, so the
// tree depends on the input only).
int BroadPhase::Build(std::vector<int>& faces, int begin, int end, const std::vector<Vec3>& centroid) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (end - begin <= kLeafFaces) {
    nodes_[id].right = begin;
    nodes_[id].faces = end - begin;
    return id;
  }
  Vec3 lo = centroid[faces[begin]], hi = lo;
  for (int i = begin; i < end; ++i) {
    lo = lo.cwiseMin(centroid[faces[i]]);
    hi = hi.cwiseMax(centroid[faces[i]]);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(faces.begin() + begin, faces.begin() + mid, faces.begin() + end, [&](int a, int b) {
    const double ca = centroid[a][axis], cb = centroid[b][axis];
    return ca < cb || (ca == cb && a < b);
  });
  const int left = Build(faces, begin, mid, centroid);
  const int right = Build(faces, mid, end, centroid);
  nodes_[id].left = left;
  nodes_[id].right = right;
  nodes_[id].faces = end - begin;
  return id;
}

// Every overlapping pair of faces from two leaves (a == b: every pair inside the leaf)
// that shares no vertex: those that do are in adjacent_vf_ and adjacent_ee_.
void BroadPhase::LeavesPair(const Node& a, const Node& b) {
  const int* fa = leaf_faces_.data() + a.right;
  const int* fb = leaf_faces_.data() + b.right;
  const Aabb* ba = leaf_boxes_.data() + a.right;
  const Aabb* bb = leaf_boxes_.data() + b.right;
  const std::array<int, 3>* va = leaf_verts_.data() + a.right;
  const std::array<int, 3>* vb = leaf_verts_.data() + b.right;
  // Branch-free: every face pair is written, the count advances past those to test.
  std::array<std::array<int, 2>, size_t{kLeafFaces} * kLeafFaces> pairs;
  int m = 0;
  for (int i = 0; i < a.faces; ++i)
    for (int j = &a == &b ? i + 1 : 0; j < b.faces; ++j) {
      pairs[m] = {fa[i], fb[j]};
      m += int(ba[i].Overlaps(bb[j])) & int(!ShareVertex(va[i], vb[j]));
    }
  for (int k = 0; k < m; ++k) LeafPair(pairs[k][0], pairs[k][1]);
}

// Branch-free like FilterBoxes: every pair is written at the end of raw_vf_ (raw_ee_),
// the count num_vf_ (num_ee_) advances past those that overlap. A face owns at most 3
// vertices and 3 edges: at most 6 VF and 9 EE pairs per call. fa and fb share no vertex
// (LeavesPair), so no vertex of one is in the other and no two of their edges meet.
void BroadPhase::LeafPair(int fa, int fb) {
  if (raw_vf_.size() < num_vf_ + 6) raw_vf_.resize(2 * raw_vf_.size() + 64);
  if (raw_ee_.size() < num_ee_ + 9) raw_ee_.resize(2 * raw_ee_.size() + 64);
  std::array<int, 2>* vf = raw_vf_.data();
  size_t n = num_vf_;
  for (int side = 0; side < 2; ++side) {
    const int owner = side ? fb : fa, f = side ? fa : fb;
    for (int k = owned_start_v_[owner]; k < owned_start_v_[owner + 1]; ++k) {
      const int v = owned_v_[k];
      vf[n] = {v, f};
      n += vbox_[v].Overlaps(fbox_[f]);
    }
  }
  num_vf_ = n;
  std::array<int, 2>* ee = raw_ee_.data();
  n = num_ee_;
  for (int i = owned_start_e_[fa]; i < owned_start_e_[fa + 1]; ++i) {
    const int a = owned_e_[i];
    for (int j = owned_start_e_[fb]; j < owned_start_e_[fb + 1]; ++j) {
      const int b = owned_e_[j];
      ee[n] = {std::min(a, b), std::max(a, b)};
      n += ebox_[a].Overlaps(ebox_[b]);
    }
  }
  num_ee_ = n;
}

void BroadPhase::QueryVertex(int v) {
  if (nodes_.empty()) return;
  std::vector<int> stack{0};
  while (!stack.empty()) {
    const Node& n = nodes_[stack.back()];
    stack.pop_back();
    if (!n.box.Overlaps(vbox_[v])) continue;
    if (n.left < 0) {
      for (int k = n.right; k < n.right + n.faces; ++k) {
        const int f = leaf_faces_[k];
        if (!FaceHas(F_, f, v) && fbox_[f].Overlaps(vbox_[v])) raw_vf_.push_back({v, f});
      }
    } else {
      stack.push_back(n.left);
      stack.push_back(n.right);
    }
  }
}

void BroadPhase::SetBoxes(const std::vector<Aabb>& vbox) {
  const int nf = static_cast<int>(F_.rows()), ne = static_cast<int>(E_.size());
  vbox_ = vbox;
  ebox_.resize(ne);
  for (int e = 0; e < ne; ++e) ebox_[e] = Aabb::Union(vbox_[E_[e][0]], vbox_[E_[e][1]]);
  fbox_.resize(nf);
  for (int f = 0; f < nf; ++f) fbox_[f] = Aabb::Union(Aabb::Union(vbox_[F_(f, 0)], vbox_[F_(f, 1)]), vbox_[F_(f, 2)]);
}

bool BroadPhase::InsideGrown(const std::vector<Aabb>& vbox) const {
  return have_superset_ && BoxesInside(vbox, grown_);
}

bool BroadPhase::InsideGrownMoved(const std::vector<Aabb>& vbox, const Points3& points) const {
  const Eigen::Index n = points.rows();
  if (!have_superset_ || search_points_.rows() != n || n == 0) return false;
  // Kabsch: x ↦ R (x − c) + c_ref, fitting points onto search_points_.
  const Vec3 c = points.colwise().mean().transpose(), c_ref = search_points_.colwise().mean().transpose();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i)
    H += (points.row(i).transpose() - c) * (search_points_.row(i).transpose() - c_ref).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
  if (!R.allFinite()) return false;
  const Eigen::Matrix3d absR = R.cwiseAbs();
  const Vec3 t = c_ref - R * c;
  // The box of a mapped box: centre R·m + t, half sizes |R|·h; rounding is covered by a
  // pad far above it (relative 1e-12 of the magnitudes involved).
  bool inside = true;
  for (size_t i = 0; i < vbox.size() && inside; ++i) {
    const Vec3 m = 0.5 * (vbox[i].lo + vbox[i].hi), h = 0.5 * (vbox[i].hi - vbox[i].lo);
    const Vec3 mc = R * m + t;
    const double pad = 1e-12 * (1 + m.cwiseAbs().maxCoeff() + t.cwiseAbs().maxCoeff() + h.cwiseAbs().maxCoeff());
    const Vec3 hc = (absR * h).array() + pad;
    const Aabb& g = grown_[i];
    inside = ((g.lo - (mc - hc)).array() <= 0).all() && (((mc + hc) - g.hi).array() <= 0).all();
  }
  return inside;
}

void BroadPhase::Find(const std::vector<Aabb>& vbox, CandidatePairs* out) { Query(vbox, nullptr, out); }

void BroadPhase::Query(const std::vector<Aabb>& vbox, const Points3* points, CandidatePairs* out) {
  if (static_cast<int>(vbox.size()) != num_vertices_)
    throw Error("broad phase: " + std::to_string(vbox.size()) + " vertex boxes for " + std::to_string(num_vertices_) +
                " vertices");
  if (!(reuse_margin_ > 0)) {
    SetBoxes(vbox);
    Search(out);
    return;
  }
  if (!InsideGrown(vbox) && !(points && InsideGrownMoved(vbox, *points))) {
    // lo − m ≤ lo and hi + m ≥ hi after rounding too: overlapping boxes still overlap.
    grown_.resize(vbox.size());
    for (size_t i = 0; i < vbox.size(); ++i)
      grown_[i] = {vbox[i].lo.array() - reuse_margin_, vbox[i].hi.array() + reuse_margin_};
    SetBoxes(grown_);
    // A new tree every kRebuildSearches searches; refitted in between (the tree's shape
    // never changes an answer, and the cloth moves little between two searches).
    if (searches_ % kRebuildSearches == 0 || nodes_.empty()) {
      std::vector<Vec3> centre(fbox_.size());
      for (size_t f = 0; f < fbox_.size(); ++f) centre[f] = 0.5 * (fbox_[f].lo + fbox_[f].hi);
      BuildTree(centre);
    }
    Search(&superset_);
    have_superset_ = true;
    if (points)
      search_points_ = *points;
    else
      search_points_.resize(0, 3);
  }
  // The superset is sorted: filtering keeps the order.
  SetBoxes(vbox);
  FilterBoxes(superset_, out);
}

void BroadPhase::FilterBoxes(const CandidatePairs& from, CandidatePairs* out) const {
  // Branch-free: every pair is written, the count advances only past those that overlap.
  out->vf.resize(from.vf.size());
  size_t k = 0;
  for (const auto& p : from.vf) {
    out->vf[k] = p;
    k += vbox_[p[0]].Overlaps(fbox_[p[1]]);
  }
  out->vf.resize(k);
  out->ee.resize(from.ee.size());
  k = 0;
  for (const auto& p : from.ee) {
    out->ee[k] = p;
    k += ebox_[p[0]].Overlaps(ebox_[p[1]]);
  }
  out->ee.resize(k);
}

void BroadPhase::Filter(const std::vector<Aabb>& vbox, const CandidatePairs& from, CandidatePairs* out) {
  if (static_cast<int>(vbox.size()) != num_vertices_)
    throw Error("broad phase: " + std::to_string(vbox.size()) + " vertex boxes for " + std::to_string(num_vertices_) +
                " vertices");
  SetBoxes(vbox);
  FilterBoxes(from, out);
}

bool BoxesInside(const std::vector<Aabb>& inner, const std::vector<Aabb>& outer) {
  if (inner.size() != outer.size()) return false;
  bool inside = true;
  for (size_t i = 0; i < inner.size() && inside; ++i) {
    const Aabb &b = inner[i], &g = outer[i];
    inside = int(g.lo[0] <= b.lo[0]) & int(g.lo[1] <= b.lo[1]) & int(g.lo[2] <= b.lo[2]) & int(b.hi[0] <= g.hi[0]) &
             int(b.hi[1] <= g.hi[1]) & int(b.hi[2] <= g.hi[2]);
  }
  return inside;
}

void BroadPhase::Search(CandidatePairs* out) {
  ++searches_;
  const int nf = static_cast<int>(F_.rows()), ne = static_cast<int>(E_.size());
  // Refit: children come after their parent.
  leaf_boxes_.resize(leaf_faces_.size());
  for (size_t k = 0; k < leaf_faces_.size(); ++k) leaf_boxes_[k] = fbox_[leaf_faces_[k]];
  for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i) {
    Node& n = nodes_[i];
    if (n.left >= 0) {
      n.box = Aabb::Union(nodes_[n.left].box, nodes_[n.right].box);
      continue;
    }
    n.box = leaf_boxes_[n.right];
    for (int k = n.right + 1; k < n.right + n.faces; ++k) n.box = Aabb::Union(n.box, leaf_boxes_[k]);
  }
  raw_vf_.clear();
  raw_ee_.clear();
  // The pairs of faces sharing a vertex: LeafPair's tests on the list made up front.
  auto filter = [](const std::vector<std::array<int, 2>>& from, const std::vector<Aabb>& first,
                   const std::vector<Aabb>& second, std::vector<std::array<int, 2>>& to) {
    size_t k = to.size();
    to.resize(k + from.size());
    for (const auto& p : from) {
      to[k] = p;
      k += first[p[0]].Overlaps(second[p[1]]);
    }
    to.resize(k);
  };
  filter(adjacent_vf_, vbox_, fbox_, raw_vf_);
  filter(adjacent_ee_, ebox_, ebox_, raw_ee_);
  num_vf_ = raw_vf_.size();
  num_ee_ = raw_ee_.size();
  // Self-traversal: (a, a) means "pairs inside subtree a".
  stack_.clear();
  if (!nodes_.empty()) stack_.push_back({0, 0});
  while (!stack_.empty()) {
    const auto [a, b] = stack_.back();
    stack_.pop_back();
    const Node &na = nodes_[a], &nb = nodes_[b];
    if (a == b) {
      if (na.left >= 0) {
        stack_.push_back({na.left, na.left});
        stack_.push_back({na.right, na.right});
        stack_.push_back({na.left, na.right});
      } else {
        LeavesPair(na, na);
      }
      continue;
    }
    if (!na.box.Overlaps(nb.box)) continue;
    if (na.left < 0 && nb.left < 0) {
      LeavesPair(na, nb);
    } else if (nb.left < 0 || (na.left >= 0 && na.faces >= nb.faces)) {  // split the larger subtree
      stack_.push_back({na.left, b});
      stack_.push_back({na.right, b});
    } else {
      stack_.push_back({a, nb.left});
      stack_.push_back({a, nb.right});
    }
  }
  raw_vf_.resize(num_vf_);
  raw_ee_.resize(num_ee_);
  for (int v : orphan_vertices_) QueryVertex(v);
  out->vf.swap(raw_vf_);
  out->ee.swap(raw_ee_);
  SortPairs(out->vf, std::max(num_vertices_, nf), tmp_, count_);
  SortPairs(out->ee, ne, tmp_, count_);
}

void BroadPhase::FindClose(const Points3& x0, const Points3& x1, double dist, double slack, CandidatePairs* out) {
  if (x0.rows() != num_vertices_ || x1.rows() != num_vertices_)
    throw Error("broad phase: FindClose expects " + std::to_string(num_vertices_) + " positions");
  PathBoxes(x0, x1, dist, slack, &path_boxes_);
  Query(path_boxes_, &x0, out);
}

void BroadPhase::FindClosePaths(const std::vector<Aabb>& path_boxes, const Points3& x0, CandidatePairs* out) {
  if (x0.rows() != num_vertices_)
    throw Error("broad phase: FindClosePaths expects " + std::to_string(num_vertices_) + " positions");
  Query(path_boxes, &x0, out);
}

CandidatePairs BruteForceClose(const Faces& F, const std::vector<std::array<int, 2>>& E, const Points3& x0,
                               const Points3& x1, double dist, double slack) {
  std::vector<Aabb> boxes;
  PathBoxes(x0, x1, dist, slack, &boxes);
  return BruteForceCandidates(F, E, boxes);
}

CandidatePairs BruteForceCandidates(const Faces& F, const std::vector<std::array<int, 2>>& E,
                                    const std::vector<Aabb>& vbox) {
  CandidatePairs out;
  std::vector<Aabb> fbox(F.rows()), ebox(E.size());
  for (int f = 0; f < F.rows(); ++f) fbox[f] = Aabb::Union(Aabb::Union(vbox[F(f, 0)], vbox[F(f, 1)]), vbox[F(f, 2)]);
  for (size_t e = 0; e < E.size(); ++e) ebox[e] = Aabb::Union(vbox[E[e][0]], vbox[E[e][1]]);
  for (int v = 0; v < static_cast<int>(vbox.size()); ++v)
    for (int f = 0; f < F.rows(); ++f)
      if (!FaceHas(F, f, v) && vbox[v].Overlaps(fbox[f])) out.vf.push_back({v, f});
  for (int a = 0; a < static_cast<int>(E.size()); ++a)
    for (int b = a + 1; b < static_cast<int>(E.size()); ++b)
      if (!EdgesShare(E[a], E[b]) && ebox[a].Overlaps(ebox[b])) out.ee.push_back({a, b});
  return out;
}

}  // namespace drape
