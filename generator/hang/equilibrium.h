// Static equilibrium of a cloth's spring model with SUNDIALS KINSOL (Newton–Krylov):
// the "stationary means stationary" step after Bullet has settled a hung garment.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "common/mesh.h"

namespace drape {

// Springs f = k·(l − L0)/L0 along the spring (k in N per unit strain), node weights
// m·g, and nodes held fixed (the gripper). Stretch springs are the mesh edges,
// bending springs join the two opposite vertices of each interior edge.
struct SpringNetwork {
  std::vector<std::array<int, 2>> springs;
  std::vector<double> rest_length;  // m, per spring
  std::vector<double> stiffness;    // N per unit strain, per spring
  std::vector<double> mass;         // kg, per node
  std::vector<char> fixed;          // per node: 1 = held
  Vec3 gravity = Vec3(0, -9.81, 0);
  // One-sided contacts keeping a node on its side of a nearby triangle (layers lying on
  // each other): penalty force k·max(0, gap − d)·dir with d = dir·(x_node − Σ w_j x_j),
  // the plane direction and barycentric weights frozen at the starting state.
  struct Contact {
    int node;
    std::array<int, 3> tri;
    Vec3 w;    // barycentric weights
    Vec3 dir;  // unit, pointing from the triangle to the node's side
    double gap;
  };
  std::vector<Contact> contacts;
  double contact_stiffness = 0;  // N/m

  int NumNodes() const { return static_cast<int>(mass.size()); }
};

// Per-node net force (spring forces + weight), #V×3, N. Fixed nodes get their
// reaction (not zeroed); callers mask them.
Points3 SpringForces(const SpringNetwork& net, const Points3& x);

struct EquilibriumOptions {
  // Stop when max over free nodes of |F_i| / (m_i g) falls below this.
  double relative_tolerance = 1e-4;
  int max_iterations = 40;         // Newton iterations of the final (c = 0) stage
  int max_total_iterations = 100;  // over all stages (cost cap)
  // A solve moving any node further than this is rejected (state kept), metres.
  double max_displacement = 0.03;
  void Validate() const;
};

struct EquilibriumReport {
  bool converged = false;    // KINSOL reached the tolerance
  bool applied = false;      // x was replaced by the solution
  int iterations = 0;        // Newton iterations
  int linear_iterations = 0; // GMRES iterations in total
  double residual_before = 0;      // max |F_i| over free nodes, N
  double residual_after = 0;       // same, for the returned state
  double relative_before = 0;      // max |F_i|/(m_i g)
  double relative_after = 0;
  double max_displacement = 0;     // of the solution vs start, m (even if rejected)
  std::string message;             // why not applied, or KINSOL's flag
};

// Solves F(x) = 0 for the free nodes starting from x (#V×3, updated in place when the
// solve converges and moves no node more than max_displacement). Newton–Krylov:
// SPGMR with an analytic Jacobian-vector product, right-preconditioned by a sparse
// LDLᵀ factorisation of the tension-only (positive definite) stiffness, line search,
// inside a proximal continuation (F + c·M·(x_prev − x) = 0 with c → 0).
EquilibriumReport SolveEquilibrium(const SpringNetwork& net, Points3& x,
                                   const EquilibriumOptions& options);

}  // namespace drape
