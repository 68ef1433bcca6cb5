// Robust collision handling for cloth, after each step of any internal dynamics
// (Bridson, Fedkiw & Anderson 2002, "Robust treatment of collisions, contact and
// friction for cloth animation"). Pure geometry: Eigen only, no Bullet.
//
// One call of CollisionHandler::Apply takes the positions before a step, x0 (assumed
// intersection-free), and the positions proposed by the dynamics, x1, and corrects x1
// in place, in this order:
//   1. strain limiting: Gauss–Seidel clamping of every mesh edge to
//      [(1−max_compression)·L0, (1+max_strain)·L0], mass-weighted;
//   2. proximity repulsion: vertex–face (VF) and edge–edge (EE) pairs that share no
//      vertex and are closer than `thickness` (at x0 or at x1) lose their approaching
//      normal motion and are pushed apart towards `thickness` (inelastic);
//   3. static box colliders (table, floor): nodes entering a box inflated by
//      thickness/2 are put back on its surface, with Coulomb friction;
//   4. continuous collision detection (CCD) on the straight path x0→x1 for every VF
//      and EE pair that shares no vertex, with inelastic impulses at the time of
//      impact, up to `ccd_iterations` passes;
//   5. the impulses (and repulsion) re-stretch edges the clamp had fixed: while some
//      edge is beyond the strain bound, clamp again, re-check the colliders and run
//      the CCD again, up to `strain_rounds` times;
//   6. fail-safe: rigid impact zones (Provot 1997, Bridson §7.4). A zone moves rigidly
//      from x0, so edges inside it keep their x0 length, but edges leaving it are
//      stretched by the zone's motion: after every zone move the free nodes are clamped
//      again with the zones' nodes held (infinitely heavy), the colliders re-checked,
//      and colliding pairs and still-violating edges (with strain_zones all of them,
//      with strain_monotone those the step made worse) both merge into zones, until
//      no pair collides and no such edge is left. A violating edge of two free nodes
//      outside every zone first freezes only its lead node (nearer the kinematic
//      nodes; a zone of its own, which stays where the step left it), so the next
//      clamp shortens the edge by moving the other node; merged whole, an edge
//      already beyond the bound at x0 would keep that length. Every round freezes a
//      node or merges two components, so this ends; as the last resort the whole
//      mesh becomes one zone.
// The caller then uses x1 as the new state and (x1 − x0)/dt as the node velocities.
//
// Guarantee: when every kinematic node (inv_mass == 0) moves rigidly as a group over
// the step (e.g. held still, or carried by one gripper), the returned path x0→x1 is
// free of VF and EE crossings between elements that share no vertex
// (report.remaining_collisions == 0): the CCD is conservative and a rigid zone moves
// by an affine map (1−t)·I + t·R that stays invertible for rotation angles < π.
// When in addition every edge of x0 is within the strain bound and strain_zones is on,
// so is every edge of the returned x1 (report.strain_violations == 0; bound: (1 + max_strain +
// strain_tolerance)·L0, and (1 − max_compression − strain_tolerance)·L0 below).
// With strain_zones off and strain_monotone on, an edge within the bound at x0 ends
// within it, and one beyond it ends no more than strain_tolerance longer (shorter,
// below it) than it started.
// Otherwise report.strain_violations counts the edges that could not be brought
// within it (an edge of x0 already beyond it inside a zone, or between kinematic nodes
// pulled apart): the caller decides (e.g. fails the job).
// Kinematic nodes that move non-rigidly relative to each other (two grippers pulling
// apart) can force a crossing no correction of free nodes can avoid; then the zones
// follow the best rigid fit of their kinematic nodes, report.nonrigid_kinematic is
// set and any crossing left is counted in report.remaining_collisions.
//
// Boxes: nodes are put back thickness/2 outside (step 3, with friction); in every CCD
// pass, cloth edges against the box's 12 edges, cloth faces against its 8 corners and
// node paths against the box itself are tested as well (the box infinitely heavy), and
// in the fail-safe a zone touching a box stays at x0. So the returned path enters no
// box (report.collider_violations == 0) unless a held node is pushed into one.
//
// Units: metres, seconds; masses enter only through inv_mass (1/kg; any consistent
// scale, only ratios matter).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "common/mesh.h"
#include "generator/cloth/broad_phase.h"

namespace drape {

// A static rigid box: table top, floor.
struct BoxCollider {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // box centre + orientation, world frame
  Vec3 half_extents{1, 1, 1};                              // m, along the box's own axes
  double friction = 0.3;                                   // Coulomb μ between cloth and this box
  void Validate() const;                                   // throws drape::Error naming the field
};

struct CollisionOptions {
  // m: VF and EE pairs closer than this are repelled; nodes are kept thickness/2
  // outside colliders.
  double thickness = 0.004;
  // m: CCD's ξ. A pair is reported as colliding when, along the path, its distance
  // could fall below min(min_separation, d0/2) (d0: its distance at x0), so a
  // corrected state keeps that margin and is intersection-free with room to spare.
  double min_separation = 1e-4;
  // Fraction of the missing distance to `thickness` that repulsion restores per call
  // (1 = all at once; smaller avoids popping layers apart at high speed).
  double repulsion_fraction = 0.25;
  // Edge strain limits relative to the rest length L0: edges are clamped to at most
  // (1+max_strain)·L0 (≤ 0: off) and at least (1−max_compression)·L0 (0: off). The
  // caller sets max_strain from the material's stretch.
  double max_strain = 0.06;
  double max_compression = 0.0;
  int strain_iterations = 20;  // Gauss–Seidel sweeps (stops early when all edges are within)
  // Strain (absolute, like max_strain) an edge may exceed the bound by and still count
  // as within it: the Gauss–Seidel clamp converges to the bound, not onto it.
  double strain_tolerance = 1e-3;
  // Clamp → colliders → CCD rounds after the first CCD before edges still beyond the
  // bound go to the fail-safe (where they merge into rigid zones).
  int strain_rounds = 3;
  // Edges still beyond the bound after those rounds merge into rigid impact zones
  // (true: every step ends within the bound). Off, they are left to the next step's
  // clamp and counted in CollisionReport::strain_violations; zones then come from
  // collisions only. Why off for hanging: a zone that takes in a held node moves with
  // the gripper, so stretched edges next to the grip froze whatever cloth their zone
  // had merged with onto it — a shirt held by its cuff kept its body bunched at the
  // cuff (fail-safe in 94 % of steps) instead of hanging 1.45 m below.
  bool strain_zones = true;
  // With strain_zones off, edges that end the step beyond the bound after starting
  // within it, or further beyond it than they started by more than strain_tolerance
  // (longer than at x0 above it, shorter below it), still merge into rigid impact
  // zones, where they keep their x0 length: no edge leaves a step worse than it came
  // in, so violations cannot compound. Why: a garment falling from
  // two grippers (the unfolding hand-over) meets itself at 4–6 m/s; the impulses of
  // that burst re-stretch edges the clamp cannot bring back within the rounds, and
  // with nothing merging them each step started from the last one's violations and
  // handed back worse ones (largest strain 0.04 → 0.33 → 0.84 → 1.02 in three steps,
  // speeds 28 m/s 60 ms later). Edges already beyond the bound at x0 are clamped
  // first like any other; only one the response would lengthen further is frozen.
  bool strain_monotone = true;
  // Sweeps run outwards from the kinematic nodes (mesh hops); on an edge between two
  // hop levels the node nearer to a held node gets its inverse mass scaled by this
  // (1: plain mass weighting, which needs hundreds of sweeps to carry a grip's pull
  // through a 1000-node garment; 0: Müller's follow-the-leader, which kinks the cloth).
  // Below 1 momentum is not conserved: a clamped edge's centre moves towards the grip,
  // which shortens a swinging cloth and pumps energy into it (a strip swung from a
  // corner gains 2.5 % of its drop energy at 0.3, 0.6 % at 0.6, 0.07 % at 0.8; at 0.3
  // four pants of the paper recipe blew up). Nearer 1 the clamp leaves more edges to
  // the fail-safe (those pants: 0–420 of ~2,000 steps at 0.6, 770–1,020 at 0.8).
  double strain_lead_weight = 0.6;
  int proximity_iterations = 2;  // Gauss–Seidel sweeps over the close pairs
  int ccd_iterations = 6;        // impulse passes before the fail-safe
  int max_zone_iterations = 50;  // impact-zone merges before the whole-mesh zone
  double cloth_friction = 0.0;   // Coulomb μ for cloth–cloth contacts
  void Validate() const;         // throws drape::Error naming the field
};

// What happened in one Apply call: counts, then timing (timing is never hashed).
struct CollisionReport {
  int strain_corrections = 0;  // edge clamps applied (summed over sweeps)
  int proximity_pairs = 0;     // VF + EE pairs repelled
  int collider_contacts = 0;   // nodes put back on a collider's surface
  int ccd_collisions = 0;      // colliding pairs found by CCD (summed over passes)
  int ccd_passes = 0;          // CCD + impulse passes run
  int box_collisions =
      0;  // cloth edges/faces/node paths found crossing a box's edges/corners/faces (summed over passes)
  int collider_violations =
      0;  // node paths, edges or faces still entering a box on the returned path (0 unless held nodes push into one)
  int impact_zones = 0;             // zones in the final fail-safe state (0: fail-safe not used)
  int zone_iterations = 0;          // fail-safe detect-and-merge rounds
  int remaining_collisions = 0;     // pairs still colliding on the returned path (0 unless non-rigid kinematics)
  bool fail_safe_used = false;      // rigid impact zones were needed
  bool reverted = false;            // gave up on zones: the whole mesh moved as one rigid zone
  bool nonrigid_kinematic = false;  // a zone's kinematic nodes moved non-rigidly
  int strain_rounds = 0;            // re-clamp rounds after the first CCD (step 5)
  int strain_merges = 0;            // edges beyond the bound merged into impact zones (step 6)
  int strain_violations = 0;  // edges of the returned x1 beyond the bound (0 unless x0 was, or non-rigid kinematics)
  double max_strain = 0;      // largest edge strain (l − L0)/L0 of the returned x1
  int broad_builds = 0;       // broad-phase candidate queries run (work counter)
  int broad_searches = 0;     // of which needed a tree search (the rest filtered the kept superset)
  long long broad_candidates = 0;  // candidate pairs found (summed over searches)
  long long ccd_tests = 0;         // pair CCD tests run (summed over passes)
  long long proximity_tests = 0;   // pairs whose closest points repulsion computed (at x0 or x1)
  // Timing only, never hashed: seconds on the steady clock (common/timing.h ClockSeconds,
  // cheap to read); a caller that wants CPU time scales a run's sums by the thread CPU
  // time it reads around the run (the hang does). total_seconds: the whole call, so
  // total − the phases is the call's own overhead (checks, copies).
  double broad_seconds = 0, strain_seconds = 0, proximity_seconds = 0, collider_seconds = 0, ccd_seconds = 0,
         zone_seconds = 0, total_seconds = 0;
};

class CollisionHandler {
 public:
  // The strain clamp's sweep order depends only on which nodes are fixed (w == 0): kept
  // from one call to the next while that set is the same (the held nodes, step after step).
  struct StrainOrder {
    std::vector<int> fixed;         // nodes with w == 0, ascending
    std::vector<int> level, order;  // hop level per node; edges by level
    bool valid = false;
    std::vector<int> stamp, checked;  // per-call scratch of the clamp (node, edge)
    // With shortcuts: what the clamp computes per edge from w, the levels, L0 and the
    // bounds, computed once for the w in `w` (bit for bit) and kept in sweep order.
    struct Edge {
      int i, j;         // nodes
      double L0;        // m, rest length
      double hi, lo;    // m: the bounds (upper, lower) times L0
      double hi2, lo2;  // m²: the squared-length test's bounds
      double fi, fj;    // the shares of a correction that move i and j
    };
    std::vector<Edge> edges;  // edges with L0 > 0 and a movable node, in `order`
    Eigen::VectorXd w;        // the w they were computed for
    bool edges_valid = false;
  };
  // Repulsion's distances at a snapshot of x0, taken every kRepelSnapshotCalls calls:
  // a pair's distance changes by at most twice the largest move of its nodes, so a
  // pair that was far enough apart there is skipped without its closest points (the
  // same answer, less work; see Repel in collision.cpp).
  struct RepelSnapshot {
    Points3 x;                               // x0 of the call that took it
    std::vector<std::array<int, 2>> vf, ee;  // that call's repulsion pairs (sorted)
    std::vector<double> d;                   // m, their distances at x: vf, then ee
    long long calls = 0;                     // Apply calls so far
  };

  // Topology and rest lengths fixed at construction (rest: the flat garment, metres).
  CollisionHandler(const Faces& F, const Points3& rest, const CollisionOptions& options);

  // x0: positions at the start of the step (intersection-free); x1: proposed by the
  // dynamics, corrected in place so that the straight path x0→x1 is collision-free
  // (see the guarantee above). inv_mass[i] == 0: node i is kinematic (held by a
  // gripper): x1[i] is prescribed and never changed (infinitely heavy). dt (s) turns
  // position changes into velocities (friction, zone momenta). friction_from (optional):
  // per node, the proposed x1 less the step's end velocity × dt. Cloth–cloth friction
  // slows a pair's relative tangential motion over the step, and with friction_from
  // never by more than brings its relative velocity at the step's end to rest: with
  // sub-steps the two differ, and friction on the mean alone reversed and sped up a mode
  // that turns within the step. Deterministic: same input → same output bytes.
  CollisionReport Apply(const Points3& x0, Points3& x1, const Eigen::VectorXd& inv_mass, double dt,
                        const std::vector<BoxCollider>& colliders, const Points3* friction_from = nullptr);

  const CollisionOptions& options() const { return options_; }
  // Switches CollisionOptions::strain_zones for the following calls (e.g. strict steps
  // to finish a run that settled with it off).
  void SetStrainZones(bool on) { options_.strain_zones = on; }
  // Off: every result the handler keeps or skips work by (the broad phase's superset
  // and the CCD's candidates taken from the repulsion's pairs, the CCD's results and
  // distances at x0 kept per pair, the repulsion's snapshot skips, the strain clamp's
  // per-edge factors kept across calls, its skip of edges found within the bound and its
  // squared-length test before the root) is computed anew in every call. The same output bytes, slower: the reference
  // the tests hold the shortcuts to. On by default.
  void SetShortcuts(bool on);
  int NumVertices() const { return num_vertices_; }
  const std::vector<std::array<int, 2>>& edges() const { return edges_; }
  const Eigen::VectorXd& rest_lengths() const { return rest_lengths_; }

 private:
  Faces F_;
  Points3 rest_;  // m: the flat garment (pairs closer than thickness at rest keep that distance)
  int num_vertices_ = 0;
  CollisionOptions options_;
  std::vector<std::array<int, 2>> edges_;         // unique, sorted
  std::vector<int> adjacency_start_, adjacency_;  // vertex → neighbouring vertices (CSR)
  Eigen::VectorXd rest_lengths_;                  // m, per edge
  BroadPhase broad_;                              // tree over the faces; its candidate superset is kept across calls
  StrainOrder strain_order_;
  RepelSnapshot repel_snapshot_;
  bool shortcuts_ = true;
};

// Smallest distance (m) between mesh elements that share no vertex, over VF and EE
// pairs; +inf when there is no such pair. 0 means the mesh touches or intersects itself.
double MinimumNonAdjacentDistance(const Faces& F, const Points3& x);

// Squared distance from p to triangle (a, b, c) and the barycentric weights w of the
// closest point (q = w0·a + w1·b + w2·c). Robust for zero-area triangles.
double PointTriangleDistanceSquared(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3* w = nullptr);
// Squared distance between segments p0p1 and q0q1 and the parameters of the closest
// points (p0 + s·(p1−p0), q0 + t·(q1−q0)). Robust for parallel and zero-length segments.
double SegmentSegmentDistanceSquared(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1,
                                     double* s = nullptr, double* t = nullptr);

// Whether p is surely at least `reach` from triangle (a, b, c), or segment p0p1 from
// q0q1, by a bound cheaper than the distances above: p's distance from the triangle's
// plane, the distance between the segments' lines. False where the triangle or the pair
// of lines is near degenerate (sine of its angle below 1e-3), where the bound's rounding
// would grow; the bound itself is off by rounding only (~1e-16 of the coordinates).
bool PointTriangleSurelyFarther(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double reach);
bool SegmentSegmentSurelyFarther(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1, double reach);

// Conservative CCD for one pair over the straight path t ∈ [0, 1] (additive CCD,
// Li, Kaufman & Jiang 2021, "Codimensional Incremental Potential Contact"): returns
// true and *toi ∈ [0, 1] when the pair's distance could come within ξ = min(min_separation,
// d0/2) of touching, where d0 is its distance at t = 0; the distance stays above ξ on
// [0, toi]. It may report a collision that is not one (and does so when its iteration
// cap is hit or when d0 == 0), it never misses one: each step advances t by at most
// 0.9·(d − ξ)/l_p, where l_p bounds the relative speed of the closest points.
bool VertexTriangleCCD(const Vec3& p0, const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& p1, const Vec3& a1,
                       const Vec3& b1, const Vec3& c1, double min_separation, double* toi);
// Same for edge (pa, pb) against edge (qa, qb); suffix 0: start of the path, 1: end.
bool EdgeEdgeCCD(const Vec3& pa0, const Vec3& pb0, const Vec3& qa0, const Vec3& qb0, const Vec3& pa1, const Vec3& pb1,
                 const Vec3& qa1, const Vec3& qb1, double min_separation, double* toi);

}  // namespace drape
