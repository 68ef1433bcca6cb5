// The paper's dissimilarity between a target folded shape S_t and a simulated one S_x
// (Eq. dissimilarity, discretised): D̃ = (1/|S_t|) Σ_i ‖q_i − y_i‖ A_i with y_i, q_i the
// barycentres of triangle i on the target and on the simulated mesh (same
// triangulation, so triangle i corresponds to triangle i), A_i the area of triangle i on
// the target and |S_t| the target's total area (both layers). Metres.
#pragma once

#include "common/mesh.h"

namespace drape::folding {

// Throws drape::Error if the meshes do not share their faces (same F) or the target has
// zero area.
double Dissimilarity(const TriMesh& target, const TriMesh& simulated);

// The paper's cost C(x) = l_x + α·D(S_t, S_x), α = 10³ (metres, so C is in metres too).
inline double FoldCost(double length, double dissimilarity, double alpha = 1e3) {
  return length + alpha * dissimilarity;
}

}  // namespace drape::folding
