// SimulateSweep: poses of the turning garment, one exact render + noise per frame.
#include "generator/sweep/sweep.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "common/error.h"
#include "common/field_error.h"
#include "common/parallel.h"
#include "common/timing.h"

namespace drape {

void SweepOptions::Validate() const {
  if (frames < 1 || frames > 100000) BadField(frames, "sweep.frames", "must be in 1..100000");
  if (!(degrees > 0 && degrees <= 3600)) BadField(degrees, "sweep.degrees", "must be in (0, 3600]");
  if (!(frame_rate > 0)) BadField(frame_rate, "sweep.frame_rate", "must be > 0");
  if (!(camera_height > 0 && camera_height < 10))
    BadField(camera_height, "sweep.camera_height", "must be in (0, 10) m");
  if (!(camera_distance > 0.1 && camera_distance < 10))
    BadField(camera_distance, "sweep.camera_distance", "must be in (0.1, 10) m");
  if (!(gripper_height > 0 && gripper_height < 10))
    BadField(gripper_height, "sweep.gripper_height", "must be in (0, 10) m");
  if (!(look_at_height >= -10 && look_at_height <= 10))
    BadField(look_at_height, "sweep.look_at_height", "must be in [-10, 10] m");
  static const char* isas[] = {"", "sse2", "sse4.2", "avx", "avx2", "avx512"};
  bool known = false;
  for (const char* s : isas) known |= embree_isa == s;
  if (!known)
    BadField(embree_isa, "sweep.embree_isa",
             "'" + embree_isa + "' is not one of sse2, sse4.2, avx, avx2, avx512 or empty");
  kinect.Validate();
}

double FrameAngle(const SweepOptions& o, int i) {
  const double total = o.degrees * M_PI / 180;
  if (!o.back_and_forth) return total * i / o.frames;
  const double a = 2 * total * i / o.frames;
  return a <= total ? a : 2 * total - a;
}

Eigen::Isometry3d CameraToWorld(const SweepOptions& o) {
  // Camera axes in the world: x right = +x, z forward towards −z tilted down by the
  // pitch, y down completes a right-handed frame.
  const double pitch = std::atan2(o.camera_height - o.look_at_height, o.camera_distance);
  const double c = std::cos(pitch), s = std::sin(pitch);
  Eigen::Matrix3d R;
  R.col(0) = Vec3(1, 0, 0);
  R.col(1) = Vec3(0, -c, s);
  R.col(2) = Vec3(0, -s, -c);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = Vec3(0, o.camera_height, o.camera_distance);
  return T;
}

Eigen::Isometry3d ObjectToWorld(const SweepOptions& o, double angle) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(Vec3(0, o.gripper_height, 0));
  T.rotate(Eigen::AngleAxisd(angle, Vec3::UnitY()));
  return T;
}

// Does the garment stay in view while it turns? Projects the nearest points of its
// bounding cylinder's rims at 16 angles; true if one leaves the image.
bool MayLeaveView(const Eigen::AlignedBox3d& b, const SweepOptions& options, const Intrinsics& K,
                  const Eigen::Isometry3d& camera_to_world) {
  for (int k = 0; k < 16; ++k) {
    const Eigen::Isometry3d o2c = camera_to_world.inverse() * ObjectToWorld(options, 2 * M_PI * k / 16);
    const double r = std::hypot(std::max(-b.min().x(), b.max().x()), std::max(-b.min().z(), b.max().z()));
    // Nearest points of the bounding cylinder's bottom and top rims.
    for (double y : {b.min().y(), b.max().y()}) {
      for (double a = 0; a < 2 * M_PI; a += M_PI / 8) {
        const Vec3 p = o2c * Vec3(r * std::cos(a), y, r * std::sin(a));
        if (p.z() <= 0) return true;
        const double u = K.fx * p.x() / p.z() + K.cx, v = K.fy * p.y() / p.z() + K.cy;
        if (u < 0 || u > K.width - 1 || v < 0 || v > K.height - 1) return true;
      }
    }
  }
  return false;
}

Sweep SimulateSweep(const TriMesh& hung, const SweepOptions& options, uint64_t seed) {
  const auto start = Clock::now();
  SweepScene scene(hung, options);
  Sweep sweep;
  sweep.intrinsics = options.kinect.intrinsics;
  sweep.options = options;
  sweep.seed = seed;
  sweep.frames.resize(options.frames);
  const Eigen::Isometry3d camera_to_world = CameraToWorld(options);
  struct Counters {
    int64_t rays = 0, roi = 0, garment = 0, valid = 0;
  };
  std::vector<Counters> counters(options.frames);
  // Contiguous chunks of frames, one scratch per chunk (buffers reused between frames;
  // every frame has its own seed, so the chunking does not change any byte).
  const int chunks = std::max(1, std::min(options.frames, options.threads > 0 ? options.threads : HardwareThreads()));
  ParallelFor(chunks, chunks, [&](int c) {
    KinectScratch scratch;
    const int begin = int(int64_t(options.frames) * c / chunks);
    const int end = int(int64_t(options.frames) * (c + 1) / chunks);
    for (int i = begin; i < end; ++i) {
      const double angle = FrameAngle(options, i);
      Rng rng(DeriveSeed(seed, "frame/" + std::to_string(i)));
      DepthFrame& f = sweep.frames[i];
      f.depth = scene.RenderKinect(angle, rng, &scratch);
      f.camera_to_world = camera_to_world;
      f.camera_to_object = ObjectToWorld(options, angle).inverse() * camera_to_world;
      f.gripper_angle = angle;
      Counters& cn = counters[i];
      cn.rays = scratch.exact.rays_cast;
      cn.roi = scratch.exact.roi_pixels;
      cn.garment = scratch.exact.garment_pixels;
      for (float z : f.depth) cn.valid += z > 0;
    }
  });
  SweepStats& st = sweep.stats;
  st.frames = options.frames;
  const double npix = double(sweep.intrinsics.width) * sweep.intrinsics.height;
  // The background image is cast once per sweep.
  st.rays_cast = options.scene
                     ? int64_t((sweep.intrinsics.width + 3) / 4 * 4) * int64_t((sweep.intrinsics.height + 3) / 4 * 4)
                     : 0;
  double garment = 0, valid = 0;
  for (const Counters& c : counters) {
    st.rays_cast += c.rays;
    st.roi_pixels += c.roi;
    garment += double(c.garment);
    valid += double(c.valid);
  }
  st.garment_pixels_mean = garment / options.frames;
  st.valid_fraction_mean = valid / (npix * options.frames);

  const Eigen::AlignedBox3d b = Bounds(hung);  // the garment only: the gripper may be cut
  if (MayLeaveView(b, options, sweep.intrinsics, camera_to_world)) {
    std::ostringstream os;
    os << "garment may leave the camera view while turning (object-frame bounds y " << b.min().y() << ".."
       << b.max().y() << " m)";
    st.warnings.push_back(os.str());
  }
  st.wall_seconds = Since(start);
  return sweep;
}

}  // namespace drape
