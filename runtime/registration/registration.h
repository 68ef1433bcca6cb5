// Registration of a database mesh (source S, e.g. an entry's hang.ply) to a sensed
// mesh (target T, e.g. recon.ply): scaling → rigid ICP on a closest-point grid →
// non-rigid deformation by secant Levenberg–Marquardt (paper §"Deformable
// Registration"), and the paper's registration error metric (§"Registration").
//
//   RegistrationResult r = Register(source, target, RegistrationOptions{});
//   r.rigid.V, r.nonrigid.V: the source's vertices after R and after R+N (same faces).
#pragma once

#include <string>
#include <vector>

#include "common/closest_point.h"
#include "common/json.h"
#include "common/mesh.h"
#include "runtime/optim/secant_lm.h"
#include "runtime/registration/energy.h"
#include "runtime/registration/grid.h"
#include "runtime/registration/rigid.h"

namespace drape::registration {

struct RegistrationOptions {
  bool scale = true;     // step 1 (paper: scale by l_T/l_S, centres aligned)
  bool nonrigid = true;  // step 3 (false = rigid only, "R")
  GridOptions grid;
  IcpOptions icp;
  // Energy weights (paper's κ, β, α; not given there). Units: E_fit is m⁴, E_area and
  // E_angle m², E_hinge dimensionless, so κ, β are in m² and α in m⁴. Defaults tuned on
  // garment-sized meshes (0.3–1 m; see registration_test / the report).
  double kappa = 1e-4;
  double beta = 1e-4;
  double alpha = 1e-8;
  // Fitting term's distance: the grid's refined query (exact distance to the ≤8 stored
  // triangles, continuous inside a cell) when true, the paper's 8-point query when false.
  bool refined_fit = true;
  optim::SecantLmOptions lm;
  void Validate() const;  // throws drape::Error naming the bad field
};

struct RegistrationReport {
  MeshFrame source_frame, target_frame;
  Similarity scaling;  // step 1
  Similarity rigid;    // steps 1+2: source → rigidly registered S̄
  GridStats grid;
  IcpReport icp;
  optim::SecantLmReport lm;
  EnergyTerms energy_before, energy_after;  // weighted terms at S̄ and at the result
  int hinges = 0;
  std::vector<std::string> warnings;
  // Timing only (seconds), never hashed.
  double grid_seconds = 0, icp_seconds = 0, nonrigid_seconds = 0, total_seconds = 0;
};

struct RegistrationResult {
  TriMesh rigid;     // R: scaled + ICP
  TriMesh nonrigid;  // R+N (== rigid when options.nonrigid is false)
  RegistrationReport report;
};

// Throws drape::Error for empty / zero-area meshes, drape::NumericalError if the
// non-rigid solve breaks down.
RegistrationResult Register(const TriMesh& source, const TriMesh& target, const RegistrationOptions& options);

// The paper's directed error: one sample per patch of `from` (patch = triangle, sample =
// its barycentre), distance to the exact closest point on `to`, weighted by the patch
// area and divided by the total area of `from`. Metres.
struct DirectedDistance {
  double mean = 0;  // the paper's number
  double rms = 0, max = 0;
  int samples = 0;
};
DirectedDistance MeasureDirected(const TriMesh& from, const ExactClosestPoint& to);
// The same over the patches of `from` whose barycentre lies within `radius` of `centre`
// (the fit around one region); samples = 0 and mean = 0 when none does.
DirectedDistance MeasureDirectedNear(const TriMesh& from, const ExactClosestPoint& to, const Vec3& centre,
                                     double radius);

// How well a registered mesh fits a target: the symmetric mean of the paper's two
// directed errors (MeasureDirected both ways), metres. `onto_target` is over `target`.
// Used to choose among registered candidates (runtime/unfolding/candidates.h) and to
// decide the category by registration (runtime/recognition/category_fit.h).
double SymmetricFit(const TriMesh& registered, const TriMesh& target, const ExactClosestPoint& onto_target);

// A source anchor vertex and, if known, the true position of that anchor on the target.
struct AnchorPair {
  std::string label;
  int source_vertex = -1;
  bool has_truth = false;
  Vec3 truth = Vec3::Zero();
};
struct AnchorTransfer {
  std::string label;
  int source_vertex = -1;
  Vec3 rigid = Vec3::Zero(), nonrigid = Vec3::Zero();  // transferred positions (R, R+N)
  bool has_truth = false;
  double error_rigid = 0, error_nonrigid = 0;  // metres, when has_truth
};
// Transferred position = the registered source vertex. Throws drape::Error for an
// out-of-range vertex.
std::vector<AnchorTransfer> TransferAnchors(const RegistrationResult& result, const std::vector<AnchorPair>& anchors);

// Everything the evaluation table needs for one (source, target) pair.
struct RegistrationEvaluation {
  DirectedDistance s_to_t_rigid, t_to_s_rigid, s_to_t_nonrigid, t_to_s_nonrigid;
  std::vector<AnchorTransfer> anchors;
  double anchor_error_rigid = 0, anchor_error_nonrigid = 0;  // mean over anchors with truth, m
  int anchors_with_truth = 0;
  RegistrationReport report;
  double seconds = 0;  // registration time (timing only)
};
RegistrationEvaluation RegisterAndEvaluate(const TriMesh& source, const TriMesh& target,
                                           const std::vector<AnchorPair>& anchors,
                                           const RegistrationOptions& options = {},
                                           RegistrationResult* result = nullptr);

// JSON views for reports and the CLI: {"scaling", "icp", "grid", "lm", "energy", ...};
// wall-clock times only under the "timing" key.
Json ToJson(const RegistrationReport& report);
Json ToJson(const RegistrationEvaluation& evaluation);

}  // namespace drape::registration
