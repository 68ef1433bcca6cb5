// Hinge bending of a cloth mesh: a bending rigidity B in N·m acting on the dihedral
// angle of every interior edge against its rest angle (discrete shells, Grinspun,
// Hirani, Desbrun & Schröder 2003), and plasticity of the rest angles (creases, Narain,
// Pfaff & O'Brien 2013, "Folding and crumpling adaptive sheets").
//
// Energy of one hinge (interior edge of rest length l between faces of rest areas A₁, A₂):
//   E = k·(θ − θ̄)²,   k = C·B·l²/(2·(A₁ + A₂))
// θ: the signed dihedral angle (0 flat), θ̄: its rest angle, θ − θ̄ wrapped to (−π, π].
// With C = 1 the sum over an equilateral mesh bent into a cylinder of curvature κ is the
// continuum's (B/2)·κ² per area for any bending direction (bending.cpp shows the sum;
// Feng et al. 2022 use the same hinge, checked against Romero et al.'s cantilever master
// curve). ARCSim's hinge, k·l²·θ²/(8·(A₁ + A₂)), is that of B = k/4. On other meshes C
// is calibrated with the cantilever (generator/hang/cantilever.h).
//
// Plasticity (Narain et al. 2013 §5): each face keeps a plastic curvature tensor S_p
// (2×2 in the flat pattern's frame); when the elastic part |S − S_p|_F of the face's
// curvature tensor S (from its three dihedral angles) exceeds the yield curvature, S_p
// moves onto the yield surface and the face's damage grows by the excess / yield; a
// hinge's rest angle is then the mean over its two faces of the angles S_p implies,
// and its stiffness is divided by (1 + weakening × its faces' mean damage).
//
// Units: metres, radians, N·m (B), joules. Pure geometry: Eigen only.
#pragma once

#include <array>
#include <vector>

#include "common/mesh.h"

namespace drape {

// An interior edge a–b with the vertex c opposite it in the face that runs a → b and
// d in the face that runs b → a (a consistently oriented mesh).
struct Hinge {
  int a = 0, b = 0, c = 0, d = 0;
  int face_c = 0, face_d = 0;  // the faces holding c and d
};

// Signed dihedral angle of the hinge in (−π, π]: 0 when the two faces are flat, the
// angle by which face (b, a, d) is turned about the edge direction a → b away from the
// plane of face (a, b, c); ±π when they are folded onto each other.
double DihedralAngle(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
// The same angle and its gradient with respect to a, b, c, d (1/m). False, with θ and
// the gradient zero, when a face is degenerate (area below 1e-12 of the edge's square).
bool DihedralAngleGradient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, double* theta,
                           std::array<Vec3, 4>* gradient);
// An angle wrapped to (−π, π].
double WrapAngle(double angle);

struct BendingOptions {
  double rigidity = 0;  // B, N·m: moment per unit width per unit curvature of one layer
  double scale = 1;     // C: the hinge energy's constant (see the file comment)
  // Plasticity: curvature (1/m) of a face's elastic bending beyond which its rest
  // curvature yields; 0: none (the rest angles never change).
  double yield_curvature = 0;
  double weakening = 0;   // stiffness ÷ (1 + weakening × damage); ≥ 0
  void Validate() const;  // throws drape::FieldError naming the field
};

// The immutable part: hinges, their rest angles and stiffnesses, and what plasticity
// needs of each face (its edges' hinges and its pattern geometry).
struct BendingModel {
  std::vector<Hinge> hinges;
  Eigen::VectorXd rest_angle;  // rad per hinge, at the start (plasticity changes the state's)
  Eigen::VectorXd stiffness;   // k per hinge, J/rad² (E = k·(θ − θ̄)²)
  BendingOptions options;
  // Per face: the hinge of each of its three edges (−1: a boundary edge) and the 3×3
  // matrix turning its edges' angles into its curvature tensor's (S00, S11, S01) and its
  // inverse (Narain et al.'s edges_to_face / face_to_edges in the flat pattern).
  std::vector<std::array<int, 3>> face_hinges;
  std::vector<Eigen::Matrix3d> edges_to_face, face_to_edges;
  bool plastic() const { return options.yield_curvature > 0; }
};

// Hinges of every interior edge of `rest` (a consistently oriented manifold mesh).
// Rest angles: with `layer` given (a flat two-layer garment: 0 front, 1 back, stitched
// seam vertices 0), a hinge between a front face and a back face (a face is in the back
// layer when one of its vertices is) is a stitched fold, rest angle ±π with the sign of
// its angle in `rest`; every other hinge rests flat (0). Without `layer` the rest angles
// are `rest`'s own dihedral angles. `factor` (empty or one per face) scales B on a face
// (a hinge takes the mean of its two faces: hems, cuffs, waistbands). Throws
// drape::Error on bad input.
BendingModel MakeBendingModel(const TriMesh& rest, const std::vector<int>& layer, const BendingOptions& options,
                              const std::vector<double>& factor = {});

// The changing part: rest angles and, with plasticity, each face's plastic curvature
// tensor (S00, S11, S01; 1/m) and damage.
struct BendingState {
  Eigen::VectorXd rest_angle;  // rad per hinge
  Points3 plastic;             // #F×3, 1/m (empty without plasticity)
  Eigen::VectorXd damage;      // per face (empty without plasticity)
};
BendingState InitialBendingState(const BendingModel& model);

// Σ k_h·(θ − θ̄)² in joules; stiffness with the state's damage.
double BendingEnergy(const BendingModel& model, const BendingState& state, const Points3& x);
// f += −∂E/∂x (N), #V×3.
void AddBendingForces(const BendingModel& model, const BendingState& state, const Points3& x, Points3& f);
// Largest eigenvalue (1/s²) of M⁻¹·H at x, where H is the Gauss–Newton Hessian of the
// energy (Σ 2k·∇θ∇θᵀ) and M the node masses (kg, #V; a node of zero or infinite mass is
// held: left out). Power iteration from a fixed start: deterministic. Symplectic Euler
// on the bending force alone is stable for steps below 2/√λ.
double BendingFrequencySquared(const BendingModel& model, const BendingState& state, const Points3& x,
                               const Eigen::VectorXd& mass);
// Narain et al.'s plastic update at x: faces whose elastic curvature exceeds the yield
// move their plastic tensor onto the yield surface; the rest angles of their hinges are
// recomputed. Returns how many faces yielded (0 without plasticity).
int UpdatePlasticity(const BendingModel& model, BendingState& state, const Points3& x);

}  // namespace drape
