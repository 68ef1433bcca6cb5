// Reconstruction accuracy: area-weighted surface samples and exact point-to-mesh
// distances through Embree's BVH point queries.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "common/closest_point.h"
#include "common/error.h"
#include "common/parallel.h"
#include "common/rng.h"
#include "generator/fusion/fusion.h"

namespace drape {

namespace {

void CheckMesh(const TriMesh& mesh, const char* what) {
  if (mesh.NumFaces() == 0 || mesh.NumVertices() == 0)
    throw Error(std::string("MeasureAccuracy: ") + what + " mesh is empty");
  if (mesh.F.minCoeff() < 0 || mesh.F.maxCoeff() >= mesh.NumVertices())
    throw Error(std::string("MeasureAccuracy: ") + what + " mesh has out-of-range face indices");
}

double Mean(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / double(v.size()); }

// Nearest-rank percentile.
double Percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const size_t rank = static_cast<size_t>(std::ceil(q * double(v.size())));
  return v[std::clamp<size_t>(rank, 1, v.size()) - 1];
}

}  // namespace

Points3 SampleSurface(const TriMesh& mesh, int samples, uint64_t seed) {
  CheckMesh(mesh, "sampled");
  const Eigen::VectorXd area = FaceAreas(mesh);
  std::vector<double> cdf(area.size());
  double acc = 0;
  for (Eigen::Index f = 0; f < area.size(); ++f) cdf[f] = (acc += area[f]);
  if (!(acc > 0)) throw Error("MeasureAccuracy: mesh has zero area");
  Rng rng(seed);
  Points3 out(samples, 3);
  for (int i = 0; i < samples; ++i) {
    const double r = rng.Uniform() * acc;
    const int f =
        static_cast<int>(std::min<size_t>(std::upper_bound(cdf.begin(), cdf.end(), r) - cdf.begin(), cdf.size() - 1));
    // Uniform point in a triangle (Osada et al. 2002).
    const double s = std::sqrt(rng.Uniform()), t = rng.Uniform();
    const Vec3 a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    out.row(i) = (1 - s) * a + s * (1 - t) * b + s * t * c;
  }
  return out;
}

std::vector<double> PointToMeshDistances(const Points3& points, const TriMesh& mesh) {
  CheckMesh(mesh, "target");
  const ExactClosestPoint closest(mesh);
  std::vector<double> dist(points.rows());
  // Each query is independent; the distance is the exact minimum whatever the order.
  ParallelFor(static_cast<int>(points.rows()), 1,
              [&](int i) { dist[i] = closest.Query(points.row(i).transpose()).distance; });
  return dist;
}

Accuracy MeasureAccuracy(const TriMesh& recon, const TriMesh& truth, int samples) {
  CheckMesh(recon, "reconstructed");
  CheckMesh(truth, "ground-truth");
  if (samples < 1) throw Error("MeasureAccuracy: samples must be >= 1");
  const uint64_t seed = DeriveSeed(0, "fusion/accuracy");
  const std::vector<double> rt = PointToMeshDistances(SampleSurface(recon, samples, seed), truth);
  const std::vector<double> tr = PointToMeshDistances(SampleSurface(truth, samples, DeriveSeed(seed, "truth")), recon);
  Accuracy a;
  a.recon_to_truth_mean = Mean(rt);
  a.recon_to_truth_p95 = Percentile(rt, 0.95);
  a.truth_to_recon_mean = Mean(tr);
  a.truth_to_recon_p95 = Percentile(tr, 0.95);
  return a;
}

}  // namespace drape
