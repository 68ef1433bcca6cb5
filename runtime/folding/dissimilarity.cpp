#include "runtime/folding/dissimilarity.h"

#include "common/error.h"

namespace drape::folding {

double Dissimilarity(const TriMesh& target, const TriMesh& simulated) {
  if (target.F.rows() != simulated.F.rows() || target.F != simulated.F)
    throw Error("dissimilarity: the target and simulated meshes have different triangles (" +
                std::to_string(target.NumFaces()) + " vs " + std::to_string(simulated.NumFaces()) + " faces)");
  if (target.V.rows() != simulated.V.rows())
    throw Error("dissimilarity: the target and simulated meshes have different vertex counts");
  const Eigen::VectorXd A = FaceAreas(target);
  const double total = A.sum();
  if (!(total > 0)) throw Error("dissimilarity: the target mesh has zero area");
  const Points3 y = FaceCentroids(target), q = FaceCentroids(simulated);
  double sum = 0;
  for (int i = 0; i < target.NumFaces(); ++i) sum += (q.row(i) - y.row(i)).norm() * A[i];
  return sum / total;
}

}  // namespace drape::folding
