// The observe phase (trial.h): the holder turns the garment in front of the Kinect, the
// frames are fused into a TSDF and its surface, and Algorithm 1 gives the feature.
#include "common/error.h"
#include "common/field_error.h"
#include "common/rng.h"
#include "common/timing.h"
#include "generator/fusion/fusion.h"
#include "runtime/unfolding/trial.h"

namespace drape::unfolding {

namespace hw = drape::hardware;

void ObserveOptions::Validate() const {
  capture.Validate();
  if (!(sensing_height == 0 || (sensing_height > 0.5 && sensing_height < 3)))
    BadField(sensing_height, "ObserveOptions.sensing_height", "must be 0 (the release's rig) or in (0.5, 3) m");
}

bool Trial::Observe(Step& s, int iteration, Feature* code) {
  const Recipe& recipe = model_.recipe();
  hw::Arm& h = world_.arm(holder_);
  auto t0 = Clock::now();
  const Sweep sweep =
      world_.camera().CaptureTurning(h, o_.observe.capture, DeriveSeed(seed_, "sweep/" + std::to_string(iteration)));
  res_.times.sensing += Since(t0);
  s.observe.frames = static_cast<int>(sweep.frames.size());
  RecordCloth(s, h.pose());
  t0 = Clock::now();
  FusionOptions fo = recipe.fusion;
  fo.threads = o_.observe.fusion_threads;
  const FusionResult fused =
      FuseFrames(sweep.frames, sweep.intrinsics, fo, DeriveSeed(seed_, "fusion/" + std::to_string(iteration)));
  if (fused.mesh.NumFaces() == 0) {
    res_.failure = "fusion: the reconstruction is empty";
    return false;
  }
  const Tsdf& tsdf = *fused.tsdf;
  *code = ExtractFeature(
      fused.mesh.V, [&tsdf](const Vec3& p) { return tsdf.Sdf(p); }, recipe.feature);
  res_.times.fusion += Since(t0);
  s.observe.recon = fused.mesh;
  return true;
}

// The cloth as it hangs now in the holder's object frame, and the holder's pose (truth,
// for the trace and --dump-meshes).
void Trial::RecordCloth(Step& s, const hw::GripperPose& hp) const {
  const Eigen::Matrix3d to_object = Eigen::AngleAxisd(-hp.wrist, Vec3::UnitY()).toRotationMatrix();
  s.truth.cloth = world_.mesh();
  for (int i = 0; i < s.truth.cloth.NumVertices(); ++i)
    s.truth.cloth.V.row(i) = (to_object * (Vec3(s.truth.cloth.V.row(i)) - hp.position)).transpose();
  s.truth.holder_position = hp.position;
  s.truth.holder_wrist = hp.wrist;
}

}  // namespace drape::unfolding
