#include "generator/cloth/broad_phase.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "common/error.h"
#include "common/rng.h"
#include "generator/cloth/collision.h"
#include "generator/cloth/rectangle.h"

namespace drape {
namespace {

Vec3 RandomVec(Rng& rng, double scale) {
  const double x = rng.Uniform(-1, 1), y = rng.Uniform(-1, 1), z = rng.Uniform(-1, 1);
  return Vec3(x, y, z) * scale;
}

// Swept boxes of random paths: most nodes move a little, some a lot (up to the
// garment's size), a few not at all; pad random per call.
std::vector<Aabb> RandomSweptBoxes(Rng& rng, const Points3& rest, double scale) {
  Points3 x0 = rest, x1 = rest;
  for (int i = 0; i < rest.rows(); ++i) {
    x0.row(i) += RandomVec(rng, 0.2 * scale).transpose();
    const double u = rng.Uniform();
    const double step = u < 0.1 ? 0.0 : u < 0.95 ? 0.5 * scale : 20 * scale;
    x1.row(i) = x0.row(i) + RandomVec(rng, step).transpose();
  }
  std::vector<Aabb> boxes;
  SweptVertexBoxes(x0, x1, rng.Uniform(0, 0.3) * scale, &boxes);
  return boxes;
}

void ExpectSame(const CandidatePairs& got, const CandidatePairs& want, const std::string& what) {
  EXPECT_EQ(got.vf, want.vf) << what << ": VF pairs differ (" << got.vf.size() << " vs " << want.vf.size() << ")";
  EXPECT_EQ(got.ee, want.ee) << what << ": EE pairs differ (" << got.ee.size() << " vs " << want.ee.size() << ")";
}

// A two-layer garment (stitched sides, layers a gap apart) under random motions,
// queried repeatedly through one refitted tree.
TEST(BroadPhase, MatchesBruteForceOnAGarment) {
  const Garment g = MakeRectangleGarment(0.3, 0.2, 0.03, /*two_layers=*/true, 0.01);
  const auto E = UniqueEdges(g.mesh);
  BroadPhase broad(g.mesh.F, E, g.mesh.V);
  size_t total = 0;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    Rng rng(DeriveSeed(seed, "broad_phase/garment"));
    const std::vector<Aabb> boxes = RandomSweptBoxes(rng, g.mesh.V, 0.03);
    CandidatePairs got;
    broad.Find(boxes, &got);
    const CandidatePairs want = BruteForceCandidates(g.mesh.F, E, boxes);
    ExpectSame(got, want, "seed " + std::to_string(seed));
    total += want.vf.size() + want.ee.size();
  }
  EXPECT_GT(total, 1000u);  // the boxes overlap a lot: the comparison is not vacuous
}

// Random triangles over random vertices (some in no face), with a tree built from an
// unrelated layout: the answer must not depend on the tree's quality.
TEST(BroadPhase, MatchesBruteForceOnATriangleSoup) {
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    Rng rng(DeriveSeed(seed, "broad_phase/soup"));
    const int nv = 60 + static_cast<int>(rng.Below(60)), nf = 40 + static_cast<int>(rng.Below(80));
    TriMesh m;
    m.V.resize(nv, 3);
    for (int i = 0; i < nv; ++i) m.V.row(i) = RandomVec(rng, 1.0).transpose();
    m.F.resize(nf, 3);
    for (int f = 0; f < nf; ++f) {
      int a = 0, b = 0, c = 0;
      while (a == b || b == c || a == c) {  // the last 10 vertices stay in no face
        a = static_cast<int>(rng.Below(nv - 10));
        b = static_cast<int>(rng.Below(nv - 10));
        c = static_cast<int>(rng.Below(nv - 10));
      }
      m.F.row(f) = Eigen::RowVector3i(a, b, c);
    }
    const auto E = UniqueEdges(m);
    Points3 layout(nv, 3);
    for (int i = 0; i < nv; ++i) layout.row(i) = RandomVec(rng, 1.0).transpose();
    BroadPhase broad(m.F, E, layout);
    for (int query = 0; query < 3; ++query) {
      const std::vector<Aabb> boxes = RandomSweptBoxes(rng, m.V, 0.1);
      CandidatePairs got;
      broad.Find(boxes, &got);
      ExpectSame(got, BruteForceCandidates(m.F, E, boxes),
                 "seed " + std::to_string(seed) + " query " + std::to_string(query));
    }
  }
}

// Random paths on the garment: most nodes share a large common motion (a fall), on
// top of small and a few large own motions.
void RandomPaths(Rng& rng, const Points3& rest, double scale, Points3* x0, Points3* x1) {
  *x0 = rest;
  *x1 = rest;
  const Vec3 common = RandomVec(rng, 3 * scale);
  for (int i = 0; i < rest.rows(); ++i) {
    x0->row(i) += RandomVec(rng, 0.2 * scale).transpose();
    const double u = rng.Uniform();
    const Vec3 own = RandomVec(rng, u < 0.9 ? 0.3 * scale : 3 * scale);
    x1->row(i) = x0->row(i) + (u < 0.05 ? Vec3::Zero() : Vec3(common + own)).transpose();
  }
}

bool Contains(const std::vector<std::array<int, 2>>& sorted, std::array<int, 2> p) {
  return std::binary_search(sorted.begin(), sorted.end(), p);
}

// MedianDisplacement's selection is exactly nth_element's middle value, also with many
// ties (nodes moving alike), outliers that throw its sample's bracket off, and sizes
// below the sample's.
TEST(BroadPhase, MedianDisplacementIsTheMiddleValue) {
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    Rng rng(DeriveSeed(seed, "broad_phase/median"));
    const int n = 1 + static_cast<int>(rng.Below(seed % 4 == 0 ? 200 : 3000));
    const int kind = static_cast<int>(seed % 5);  // 0: spread, 1: ties, 2: all equal, 3: sorted, 4: outliers
    Points3 x0 = Points3::Zero(n, 3), x1(n, 3);
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) {
        const double u = rng.Uniform(-1, 1);
        x1(i, k) = kind == 1 ? std::round(4 * u) : kind == 2 ? 0.25 : kind == 3 ? i * 1e-3 : u;
        if (kind == 4 && i % 7 == 0) x1(i, k) = 1e6 * (i % 2 ? 1 : -1);
      }
    const Vec3 got = MedianDisplacement(x0, x1);
    for (int k = 0; k < 3; ++k) {
      std::vector<double> d(n);
      for (int i = 0; i < n; ++i) d[i] = x1(i, k) - x0(i, k);
      std::nth_element(d.begin(), d.begin() + n / 2, d.end());
      EXPECT_EQ(got[k], d[n / 2]) << "seed " << seed << ", axis " << k << ", " << n << " values";
    }
  }
}

TEST(BroadPhase, FindCloseMatchesBruteForce) {
  const Garment g = MakeRectangleGarment(0.3, 0.2, 0.03, /*two_layers=*/true, 0.01);
  const auto E = UniqueEdges(g.mesh);
  BroadPhase broad(g.mesh.F, E, g.mesh.V);
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    Rng rng(DeriveSeed(seed, "broad_phase/close"));
    Points3 x0, x1;
    RandomPaths(rng, g.mesh.V, 0.03, &x0, &x1);
    const double dist = rng.Uniform(0.001, 0.02), slack = rng.Uniform(0, 0.005);
    CandidatePairs got;
    broad.FindClose(x0, x1, dist, slack, &got);
    ExpectSame(got, BruteForceClose(g.mesh.F, E, x0, x1, dist, slack), "seed " + std::to_string(seed));
  }
}

// The culls are conservative: every pair that comes within dist on a path x0 → y1
// with y1 within slack of x1 (distances sampled densely along the path) is kept.
TEST(BroadPhase, FindCloseKeepsEveryPairThatComesClose) {
  const Garment g = MakeRectangleGarment(0.2, 0.15, 0.03, /*two_layers=*/true, 0.01);
  const auto E = UniqueEdges(g.mesh);
  const Faces& F = g.mesh.F;
  BroadPhase broad(F, E, g.mesh.V);
  size_t close_pairs = 0;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    Rng rng(DeriveSeed(seed, "broad_phase/conservative"));
    Points3 x0, x1;
    RandomPaths(rng, g.mesh.V, 0.03, &x0, &x1);
    const double dist = 0.01, slack = 0.003;
    CandidatePairs got;
    broad.FindClose(x0, x1, dist, slack, &got);
    Points3 y1 = x1;  // an end within slack of x1
    for (int i = 0; i < y1.rows(); ++i) {
      const Vec3 d = RandomVec(rng, 1.0);
      y1.row(i) += (slack * rng.Uniform() * d / std::max(d.norm(), 1e-12)).transpose();
    }
    for (int step = 0; step <= 32; ++step) {
      const Points3 x = x0 + (step / 32.0) * (y1 - x0);
      auto P = [&](int i) { return Vec3(x.row(i).transpose()); };
      for (int v = 0; v < x.rows(); ++v)
        for (int f = 0; f < F.rows(); ++f) {
          if (F(f, 0) == v || F(f, 1) == v || F(f, 2) == v) continue;
          if (PointTriangleDistanceSquared(P(v), P(F(f, 0)), P(F(f, 1)), P(F(f, 2))) >= dist * dist) continue;
          ++close_pairs;
          EXPECT_TRUE(Contains(got.vf, {v, f})) << "seed " << seed << " VF " << v << " " << f;
        }
      for (int a = 0; a < static_cast<int>(E.size()); ++a)
        for (int b = a + 1; b < static_cast<int>(E.size()); ++b) {
          if (E[a][0] == E[b][0] || E[a][0] == E[b][1] || E[a][1] == E[b][0] || E[a][1] == E[b][1]) continue;
          if (SegmentSegmentDistanceSquared(P(E[a][0]), P(E[a][1]), P(E[b][0]), P(E[b][1])) >= dist * dist) continue;
          ++close_pairs;
          EXPECT_TRUE(Contains(got.ee, {a, b})) << "seed " << seed << " EE " << a << " " << b;
        }
    }
  }
  EXPECT_GT(close_pairs, 100u);  // not vacuous
}

// Superset reuse: a sequence of queries on a garment that moves a little between them
// (mostly less than the margin, sometimes more), answered by one broad phase with reuse
// on, gives exactly the brute-force pairs every time; most queries need no tree search.
TEST(BroadPhase, ReuseMatchesBruteForceOverAMotion) {
  const Garment g = MakeRectangleGarment(0.3, 0.2, 0.03, /*two_layers=*/true, 0.01);
  const auto E = UniqueEdges(g.mesh);
  BroadPhase reuse(g.mesh.F, E, g.mesh.V);
  const double margin = 0.004;
  reuse.SetReuseMargin(margin);
  Rng rng(DeriveSeed(7, "broad_phase/reuse"));
  Points3 x0 = g.mesh.V, x1 = g.mesh.V;
  int queries = 0;
  size_t total = 0;
  for (int step = 0; step < 40; ++step) {
    x0 = x1;
    const double scale = step % 10 == 9 ? 0.02 : 0.0005;  // every tenth step a jump past the margin
    for (int i = 0; i < x1.rows(); ++i) x1.row(i) += RandomVec(rng, scale).transpose();
    for (const double dist : {0.008, 0.002}) {  // a wide and a narrow query per step, as the handler's
      CandidatePairs got;
      reuse.FindClose(x0, x1, dist, 0.001, &got);
      ++queries;
      const CandidatePairs want = BruteForceClose(g.mesh.F, E, x0, x1, dist, 0.001);
      ExpectSame(got, want, "step " + std::to_string(step) + " dist " + std::to_string(dist));
      total += want.vf.size() + want.ee.size();
    }
  }
  EXPECT_GT(total, 1000u);
  EXPECT_LT(reuse.searches(), queries / 2);  // the superset served most queries
  EXPECT_GE(reuse.searches(), 4);            // and the jumps forced new searches
}

// The CCD takes its candidates from the repulsion's answer when its boxes lie inside the
// repulsion's (BoxesInside, then Filter): the same pairs as a search, over a motion where
// the narrow boxes are mostly inside the wide ones and sometimes (a jump) are not.
TEST(BroadPhase, FilterOfAnEnclosingAnswerIsTheSearch) {
  const Garment g = MakeRectangleGarment(0.3, 0.2, 0.03, /*two_layers=*/true, 0.01);
  const auto E = UniqueEdges(g.mesh);
  BroadPhase broad(g.mesh.F, E, g.mesh.V);
  broad.SetReuseMargin(0.004);
  Rng rng(DeriveSeed(7, "broad_phase/filter"));
  Points3 x0 = g.mesh.V, x1 = g.mesh.V;
  int inside = 0, outside = 0;
  size_t total = 0;
  for (int step = 0; step < 30; ++step) {
    x0 = x1;
    for (int i = 0; i < x1.rows(); ++i) x1.row(i) += RandomVec(rng, 0.002).transpose();
    std::vector<Aabb> wide, narrow;
    PathBoxes(x0, x1, 0.008, 0, &wide);
    CandidatePairs near;
    broad.FindClosePaths(wide, x0, &near);
    ExpectSame(near, BruteForceCandidates(g.mesh.F, E, wide), "wide, step " + std::to_string(step));
    for (int k = 0; k < 3; ++k) {  // corrections of x1: small, then (every third step) one node far
      Points3 y1 = x1;
      for (int i = 0; i < y1.rows(); ++i) y1.row(i) += RandomVec(rng, 0.0005).transpose();
      if (k == 2 && step % 3 == 0) y1.row(step % y1.rows()) += Vec3(0.01, 0, 0).transpose();
      PathBoxes(x0, y1, 0.0001, 0.001, &narrow);
      const CandidatePairs want = BruteForceCandidates(g.mesh.F, E, narrow);
      if (!BoxesInside(narrow, wide)) {
        ++outside;
        continue;
      }
      ++inside;
      CandidatePairs got;
      broad.Filter(narrow, near, &got);
      ExpectSame(got, want, "step " + std::to_string(step) + " correction " + std::to_string(k));
      total += want.vf.size() + want.ee.size();
    }
  }
  EXPECT_GT(inside, 40);
  EXPECT_GT(outside, 5);
  EXPECT_GT(total, 1000u);
  EXPECT_FALSE(BoxesInside(std::vector<Aabb>(2), std::vector<Aabb>(3)));
}

// Superset reuse under whole-garment motion: the same garment at rigid poses far apart
// (turned by up to 0.25 rad, moved by up to 0.5 m: far more than the margin) keeps the
// superset of the first search, since FindClose compares boxes in the frame that best
// fits x0 to that search's; the pairs are the brute-force ones at every pose.
TEST(BroadPhase, ReuseFollowsARigidlyMovingGarment) {
  const Garment g = MakeRectangleGarment(0.3, 0.2, 0.03, /*two_layers=*/true, 0.01);
  const auto E = UniqueEdges(g.mesh);
  BroadPhase reuse(g.mesh.F, E, g.mesh.V);
  reuse.SetReuseMargin(0.004);
  size_t total = 0;
  for (int k = 0; k < 6; ++k) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.05 * k, Vec3(0.2, 1, 0.1).normalized()).toRotationMatrix();
    const Vec3 t(0.1 * k, -0.05 * k, 0.02 * k);
    Points3 x = g.mesh.V;
    for (int i = 0; i < x.rows(); ++i) x.row(i) = (R * g.mesh.V.row(i).transpose() + t).transpose();
    CandidatePairs got;
    reuse.FindClose(x, x, 0.008, 0.001, &got);
    const CandidatePairs want = BruteForceClose(g.mesh.F, E, x, x, 0.008, 0.001);
    ExpectSame(got, want, "pose " + std::to_string(k));
    total += want.vf.size() + want.ee.size();
  }
  EXPECT_GT(total, 1000u);
  EXPECT_EQ(reuse.searches(), 1);
  // The same boxes through Find (no positions to fit a frame to): every pose searches again.
  BroadPhase plain(g.mesh.F, E, g.mesh.V);
  plain.SetReuseMargin(0.004);
  for (int k = 0; k < 2; ++k) {
    Points3 x = g.mesh.V;
    x.col(0).array() += 0.1 * k;
    std::vector<Aabb> boxes;
    PathBoxes(x, x, 0.008, 0.001, &boxes);
    CandidatePairs got;
    plain.Find(boxes, &got);
  }
  EXPECT_EQ(plain.searches(), 2);
}

// Boxes just outside the grown ones force a new search: a pair that only overlaps once
// a box leaves its grown box is found.
TEST(BroadPhase, ReuseSearchesAgainWhenABoxLeavesItsGrownBox) {
  TriMesh m;
  m.V.resize(6, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0,  //
      0, 0, 1, 1, 0, 1, 0, 1, 1;
  m.F.resize(2, 3);
  m.F << 0, 1, 2, 3, 4, 5;
  const auto E = UniqueEdges(m);
  BroadPhase broad(m.F, E, m.V);
  broad.SetReuseMargin(0.1);
  CandidatePairs got;
  std::vector<Aabb> boxes;
  SweptVertexBoxes(m.V, m.V, 0.01, &boxes);
  broad.Find(boxes, &got);
  EXPECT_TRUE(got.vf.empty() && got.ee.empty());  // the triangles are 1 m apart
  Points3 x1 = m.V;
  x1.col(2).head(3).setConstant(0.985);  // the lower triangle rises to 1.5 cm under the upper one
  SweptVertexBoxes(m.V, x1, 0.01, &boxes);
  broad.Find(boxes, &got);
  ExpectSame(got, BruteForceCandidates(m.F, E, boxes), "after the rise");
  EXPECT_FALSE(got.vf.empty());
  EXPECT_EQ(broad.searches(), 2);
  EXPECT_THROW(broad.SetReuseMargin(-1), Error);
}

TEST(BroadPhase, RejectsEdgesThatAreNoSideOfAFace) {
  TriMesh m;
  m.V = Points3::Zero(4, 3);
  m.F.resize(1, 3);
  m.F << 0, 1, 2;
  std::vector<std::array<int, 2>> E = UniqueEdges(m);
  E.push_back({2, 3});
  EXPECT_THROW(BroadPhase(m.F, E, m.V), Error);
  BroadPhase broad(m.F, UniqueEdges(m), m.V);
  CandidatePairs out;
  EXPECT_THROW(broad.Find(std::vector<Aabb>(3), &out), Error);  // one box per vertex
}

}  // namespace
}  // namespace drape
