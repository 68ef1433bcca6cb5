#include "runtime/folding/evaluate.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/rng.h"
#include "common/timing.h"

namespace drape::folding {

FoldScene MakeScene(const FoldSetup& s, double friction_scale, double stiffness_scale, double density_scale) {
  s.table.Validate();
  ClothMaterial m = s.material;
  m.link_stiffness = std::min(1.0, m.link_stiffness * stiffness_scale);
  m.area_density *= density_scale;
  FoldScene scene;
  scene.model = MakeClothModel(s.garment.mesh, s.garment.layer, m, s.cloth);
  scene.table_top = s.table.top;
  scene.table.half_extents = Vec3(s.table.half_x, s.table.thickness / 2, s.table.half_z);
  scene.table.pose.translation() = Vec3(0, s.table.top - s.table.thickness / 2, 0);
  scene.table.friction = s.friction * friction_scale;
  return scene;
}

Points3 LaidGarment(const FoldSetup& s, const Vec2& offset, double yaw) {
  if (s.lying.rows() > 0) return tabletop::PlaceOnTable(s.lying, s.garment.mesh, s.table, offset, yaw);
  return tabletop::LayFlat(s.garment.mesh, s.table, offset, yaw);
}

void TrialOptions::Validate() const {
  if (trials < 0) throw Error("TrialOptions.trials must be >= 0");
  if (!(friction_jitter >= 0 && friction_jitter < 1)) throw Error("TrialOptions.friction_jitter must be in [0, 1)");
  if (!(material_jitter >= 0 && material_jitter < 1)) throw Error("TrialOptions.material_jitter must be in [0, 1)");
  if (!(placement_offset >= 0)) throw Error("TrialOptions.placement_offset must be >= 0");
  if (!(d_fraction > 0)) throw Error("TrialOptions.d_fraction must be > 0");
  if (!(inside > 0 && inside <= 1)) throw Error("TrialOptions.inside must be in (0, 1]");
}

double SilhouetteInside(const TriMesh& shape, const TriMesh& reference, double tolerance, double mpp) {
  Points3 both(shape.NumVertices() + reference.NumVertices(), 3);
  both << shape.V, reference.V;
  const tabletop::TopDownCamera cam = tabletop::FrameCamera(both, mpp, tolerance + 0.02);
  const cv::Mat a = tabletop::TopDownMask(shape, cam), b = tabletop::TopDownMask(reference, cam);
  cv::Mat grown;
  const int r = static_cast<int>(std::ceil(tolerance / mpp));
  cv::dilate(b, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
  const double total = cv::countNonZero(a);
  cv::Mat in;
  cv::bitwise_and(a, grown, in);
  return total > 0 ? cv::countNonZero(in) / total : 0.0;
}

double SilhouetteReach(const TriMesh& shape, const TriMesh& reference, double fraction, double mpp) {
  if (!(fraction > 0 && fraction <= 1)) throw Error("SilhouetteReach: fraction must be in (0, 1]");
  Points3 both(shape.NumVertices() + reference.NumVertices(), 3);
  both << shape.V, reference.V;
  const tabletop::TopDownCamera cam = tabletop::FrameCamera(both, mpp, 0.05);
  const cv::Mat a = tabletop::TopDownMask(shape, cam), b = tabletop::TopDownMask(reference, cam);
  // Distance of every pixel to the nearest reference pixel (0 inside it).
  cv::Mat outside = b == 0, dist;
  cv::distanceTransform(outside, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::vector<float> d;
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x)
      if (a.at<uchar>(y, x)) d.push_back(dist.at<float>(y, x));
  if (d.empty()) return 0;
  const size_t k = std::min(d.size() - 1, static_cast<size_t>(std::ceil(fraction * d.size())) - 1);
  std::nth_element(d.begin(), d.begin() + k, d.end());
  return d[k] * mpp;
}

void JudgeFold(TrialResult& r, const Faces& F, const TrialOptions& o) {
  const Vec3 lo = r.run.flat.colwise().minCoeff(), hi = r.run.flat.colwise().maxCoeff();
  r.diagonal = std::hypot(hi.x() - lo.x(), hi.z() - lo.z());
  r.final_dissimilarity = r.run.final_dissimilarity;
  r.inside_fraction = SilhouetteInside(TriMesh{r.run.final, F}, r.run.ideal, o.silhouette_tolerance, 0.004);
  r.reach = SilhouetteReach(TriMesh{r.run.final, F}, r.run.ideal, o.inside, 0.004);
  r.sim_time = 0;
  for (const auto& s : r.run.steps) r.sim_time += s.result.after.sim_time;
  const bool d_ok = r.final_dissimilarity <= o.d_fraction * r.diagonal;
  const bool in_ok = r.inside_fraction >= o.inside;
  r.success = d_ok && in_ok;
  r.failure.clear();
  if (!d_ok) r.failure = "D above the threshold";
  if (!in_ok) r.failure += std::string(r.failure.empty() ? "" : "; ") + "silhouette outside the target's";
}

TrialResult RunTrial(const FoldSetup& setup, const FoldingPlan& plan, const PlanRunOptions& run_options,
                     const std::vector<std::vector<RelativeTrajectory>>& trajectories, const TrialOptions& o,
                     int index) {
  o.Validate();
  const auto t0 = Clock::now();
  Rng rng(DeriveSeed(o.seed, "fold/trial/" + std::to_string(index)));
  TrialResult r;
  r.index = index;
  r.friction_scale = rng.Uniform(1 - o.friction_jitter, 1 + o.friction_jitter);
  r.stiffness_scale = rng.Uniform(1 - o.material_jitter, 1 + o.material_jitter);
  r.density_scale = rng.Uniform(1 - o.material_jitter, 1 + o.material_jitter);
  const double radius = o.placement_offset * std::sqrt(rng.Uniform()), angle = rng.Uniform(0, 2 * M_PI);
  r.offset = radius * Vec2(std::cos(angle), std::sin(angle));
  r.yaw_deg = rng.Uniform(-o.yaw_deg, o.yaw_deg);
  const FoldScene scene = MakeScene(setup, r.friction_scale, r.stiffness_scale, r.density_scale);
  const Points3 laid = LaidGarment(setup, r.offset, r.yaw_deg * M_PI / 180);
  // Both kinds end this trial only: the next one starts from its own seed.
  auto stop = [&](const std::exception& e) {
    r.failure = e.what();
    for (const auto& s : r.run.steps) r.sim_time += s.result.after.sim_time;
    r.wall_seconds = Since(t0);
  };
  try {
    RunPlan(r.run, scene, laid, setup.garment.category, plan, run_options, &trajectories);
  } catch (const NumericalError& e) {
    stop(e);
    return r;
  } catch (const Error& e) {
    stop(e);
    return r;
  }
  r.completed = true;
  JudgeFold(r, setup.garment.mesh.F, o);
  r.wall_seconds = Since(t0);
  return r;
}

std::vector<TrialResult> RunTrials(const FoldSetup& setup, const FoldingPlan& plan, const PlanRunOptions& run_options,
                                   const std::vector<std::vector<RelativeTrajectory>>& trajectories,
                                   const TrialOptions& options, const std::function<void(const TrialResult&)>& done) {
  options.Validate();
  std::vector<TrialResult> out;
  for (int t = 0; t < options.trials; ++t) {
    out.push_back(RunTrial(setup, plan, run_options, trajectories, options, t));
    if (done) done(out.back());
  }
  return out;
}

}  // namespace drape::folding
