// The non-rigid registration energy (paper Eq. energy) written as a sum of squared
// residuals, E(x) = ‖r(x)‖², over the source vertex positions x (3·#V, vertex v at
// x[3v..3v+2]):
//   fit   (one row per triangle i):  r = √Ā_i · dist(g_i)               → Σ dist(g_i)² Ā_i
//   area  (one row per triangle):    r = √(κ Ā_i / 2) (A_i/Ā_i − 1)      → κ E_area
//   angle (three rows per triangle): r = √(β Ā_i / 6) (θ_ik/θ̄_ik − 1)    → β E_angle
//   hinge (one row per interior edge): r = √(α ‖ē‖ / h̄_e) (θ_e − θ̄_e)    → α E_hinge
// Barred quantities come from the rest shape S̄ (the rigidly registered source).
// θ_e is the signed dihedral angle between the normals of the two triangles of edge e
// (so the residual is smooth through flat hinges; equal to the paper's unsigned angle
// difference whenever both have the same sign); h̄_e is a third of the sum of the two
// triangles' heights over e. Units: fit m⁴, area/angle m² (× κ, β), hinge 1 (× α).
#pragma once

#include <Eigen/Sparse>
#include <functional>

#include "common/closest_point.h"
#include "common/mesh.h"

namespace drape::registration {

using ClosestPointFn = std::function<ClosestPoint(const Vec3&)>;
using SparseRowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

struct EnergyWeights {
  double kappa = 1;  // area
  double beta = 1;   // angle
  double alpha = 1;  // hinge
};

// Energies per term, already multiplied by their weights (total = sum).
struct EnergyTerms {
  double fit = 0, area = 0, angle = 0, hinge = 0;
  double total() const { return fit + area + angle + hinge; }
};

class RegistrationEnergy {
 public:
  // rest: S̄ (faces define the unknowns' connectivity). closest: distance to the target
  // (the grid's refined query in registration; exact queries in tests).
  // Degenerate rest triangles/angles/hinges (zero area, angle or height) get zero rows.
  RegistrationEnergy(const TriMesh& rest, ClosestPointFn closest, const EnergyWeights& weights);

  int NumResiduals() const { return rows_; }
  int NumParameters() const { return 3 * num_vertices_; }
  // Row ranges [begin, end) of each term.
  int fit_begin() const { return 0; }
  int area_begin() const { return num_faces_; }
  int angle_begin() const { return 2 * num_faces_; }
  int hinge_begin() const { return 5 * num_faces_; }
  int NumHinges() const { return static_cast<int>(hinges_.size()); }

  void Residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const;
  // Analytic Jacobian, #rows × 3#V; the sparsity pattern is the same for every x
  // (entries that happen to be zero are stored).
  void Jacobian(const Eigen::VectorXd& x, SparseRowMatrix& J) const;
  EnergyTerms Terms(const Eigen::VectorXd& x) const;
  EnergyTerms TermsFromResiduals(const Eigen::VectorXd& r) const;

  static Eigen::VectorXd Flatten(const Points3& V);
  static Points3 Unflatten(const Eigen::VectorXd& x);

 private:
  struct Hinge {
    int v[4];                   // edge x0→x1 as in face A; x2 opposite in face A, x3 opposite in face B
    double rest_angle, weight;  // weight = √(α‖ē‖/h̄)
  };
  Faces F_;
  int num_vertices_ = 0, num_faces_ = 0, rows_ = 0;
  ClosestPointFn closest_;
  Eigen::VectorXd fit_w_, area_w_, rest_area_;  // per face
  Eigen::MatrixX3d angle_w_, rest_angle_;       // per face × corner
  std::vector<Hinge> hinges_;
};

// Signed dihedral angle of hinge (x0, x1; x2, x3) and its gradient (12 entries, in
// the order x0, x1, x2, x3). Exposed for tests.
double HingeAngle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, Eigen::Matrix<double, 12, 1>* grad);
// Interior angle at a in triangle (a, b, c) and its gradient (a, b, c).
double CornerAngle(const Vec3& a, const Vec3& b, const Vec3& c, Eigen::Matrix<double, 9, 1>* grad);
// Triangle area and its gradient (a, b, c).
double TriangleArea(const Vec3& a, const Vec3& b, const Vec3& c, Eigen::Matrix<double, 9, 1>* grad);

}  // namespace drape::registration
