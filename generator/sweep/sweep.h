// Synthetic Kinect v1 sweeps of a hung garment turning on the gripper (paper §"3D
// Reconstruction": the robot turns the garment 360° in ~10 s while a Kinect at 1.2 m
// height captures ~300 depth frames at 30 fps), ray cast with Embree, with a
// structured-light depth-noise model; plus a single-ray IR range sensor on the same
// scene (paper §"Search for Best Grasping Point by Local Curvature").
//
// Set-up (world frame, y up, metres; all defaults, all options):
//   gripper (grasp point = object-frame origin) at (0, gripper_height=1.5, 0); the
//   garment hangs below it and turns about the world y axis through the gripper.
//   Kinect at (0, camera_height=1.2, camera_distance=1.7), looking towards −z, tilted
//   down so that its optical axis crosses the turning axis at look_at_height=0.9 m
//   (pitch ≈ 10°). With 640×480, f=525 the view covers y ≈ 0.03…1.64 m on the turning
//   axis; a garment hanging 1.2 m below the gripper (pants by a cuff) and up to 0.3 m
//   from the axis stays in view on the near side too (y ≥ 0.24 m at 1.4 m), with the
//   gripper and ~3 cm of arm above it (SweepStats.warnings says when a garment leaves
//   the view); 1 m of garment spans ~310 px.
//   Background (scene=true): gripper (palm + two fingers, turns with the garment;
//   fingers reach down to y=−0.015 in the object frame, palm up to +0.11), a bit of
//   arm (a vertical cylinder above the palm, then a horizontal link to the back, world
//   fixed), a back wall at z=−1.2, a floor at y=0 and a table (top 0.72–0.75 m) to the
//   camera's right behind the garment.
//
// Frames: camera x right, y down, z forward (OpenCV). Gripper angle θ_i turns the
// garment counter-clockwise seen from above (right-handed about +y):
//   object_to_world(θ) = T(0, gripper_height, 0) · R_y(θ)
//   camera_to_object   = object_to_world(θ)^{-1} · camera_to_world.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "common/mesh.h"
#include "common/rng.h"

namespace drape {

// Kinect v1 (structured light) depth camera. Every noise term has its source in
// kinect_noise.cpp. noise=false gives the exact ray-cast z-depth (still range-cut).
struct KinectOptions {
  Intrinsics intrinsics;              // default 640×480, fx=fy=525, cx=319.5, cy=239.5
  double min_range = 0.5;             // m; nearer/farther readings are 0 (no data)
  double max_range = 4.0;             // m
  bool noise = true;                  // master switch; the switches below act only if true
  bool axial = true;                  // σ_z(z, θ) Gaussian along the ray (Nguyen et al. 2012)
  bool lateral = true;                // σ_L(θ) px resampling offset (Nguyen et al. 2012)
  bool quantize = true;               // 1/8 px disparity steps (Khoshelham & Elberink 2012)
  bool dropouts = true;               // grazing angles, depth edges, projector shadows
  double baseline = 0.075;            // m, IR projector ↔ IR camera
  double disparity_focal = 580.0;     // px, focal length of the IR camera (quantisation)
  double disparity_subpixel = 0.125;  // px, disparity quantisation step
  double grazing_start_deg = 75.0;    // incidence angle where dropouts start ...
  double grazing_full_deg = 85.0;     // ... and where every pixel is dropped
  double edge_jump = 0.03;            // m, a 4-neighbour depth jump above this is an edge
  double edge_dropout_probability = 0.5;
  bool projector_shadow = true;  // no data where the projector cannot see the point
  void Validate() const;
};

struct SweepOptions {
  int frames = 300;                 // total frames (both directions if back_and_forth)
  double degrees = 360;             // turn of the gripper (one way)
  bool back_and_forth = false;      // turn `degrees` one way, then back (unfolding set-up, ~550 frames)
  double frame_rate = 30;           // Hz, for timestamps only
  double camera_height = 1.2;       // m (paper)
  double camera_distance = 1.7;     // m, horizontal distance camera → turning axis
  double gripper_height = 1.5;      // m, world y of the grasp point
  double look_at_height = 0.9;      // m, where the optical axis crosses the turning axis
  bool scene = true;                // gripper, arm, table, wall, floor
  int threads = 1;                  // frames rendered in parallel (<= 0: all cores); no effect on bytes
  std::string embree_isa = "avx2";  // Embree's ISA ("" = its best); every ISA gives the same bytes
  KinectOptions kinect;
  void Validate() const;
};

struct SweepStats {
  int frames = 0;
  int64_t rays_cast = 0;           // garment-scene rays (region of interest only) + background
  int64_t roi_pixels = 0;          // sum over frames of region-of-interest pixels
  double garment_pixels_mean = 0;  // pixels per frame whose nearest hit is the garment
  double valid_fraction_mean = 0;  // fraction of pixels with data
  std::vector<std::string> warnings;
  double wall_seconds = 0;  // timing only, never hashed
};

struct Sweep {
  Intrinsics intrinsics;
  std::vector<DepthFrame> frames;
  SweepStats stats;
  SweepOptions options;  // as simulated (ReadSweep restores what cameras.json keeps)
  uint64_t seed = 0;
};

// Angle of frame i (radians): i·degrees/frames, or with back_and_forth
// i·2·degrees/frames up to `degrees`, then back.
double FrameAngle(const SweepOptions&, int i);
// The fixed camera pose in the world (see the header comment).
Eigen::Isometry3d CameraToWorld(const SweepOptions&);
// T(0, gripper_height, 0) · R_y(angle).
Eigen::Isometry3d ObjectToWorld(const SweepOptions&, double angle);

// Exact ray-cast depth of one frame: z-depth (m, +inf = nothing hit) and the cosine of
// the incidence angle, both row-major height×width.
struct ExactFrame {
  std::vector<float> depth;
  std::vector<float> cos_incidence;
  int garment_pixels = 0;
  int64_t rays_cast = 0;
  int64_t roi_pixels = 0;
};

// Pixel rectangle [u0, u1) × [v0, v1), aligned to 4×4 tiles.
struct PixelRect {
  int u0 = 0, v0 = 0, u1 = 0, v1 = 0;
  int64_t Area() const { return int64_t(u1 - u0) * (v1 - v0); }
};

// The deterministic part of the noise model, per pixel (row-major height×width): Gaussian
// σ of the axial noise (m), lateral σ (px), dropout probability (grazing angle, depth
// edge), whether the projector lights the pixel's surface, and the running minimum of
// projector columns from the right (for updating a region). ApplyKinectNoise =
// DrawKinectNoise(PlanKinectNoise(exact)); a sweep plans the static background once and
// re-plans only the region around the garment per frame (same bytes).
struct KinectPlan {
  std::vector<float> sigma_axial, sigma_lateral, p_drop, shadow_suffix;
  std::vector<float> lit;  // 1 or 0
};
// Reusable buffers for the noise of one frame (per thread); no effect on results.
struct KinectScratch {
  ExactFrame exact;
  KinectPlan plan;
  // What differs from the scene's background in exact/plan (restored before reuse).
  const void* owner = nullptr;
  PixelRect exact_dirty, plan_dirty;
  std::vector<float> na, uni, nu, nv, measured;
  std::vector<int8_t> du, dv;
};

// Infrared range sensor at the gripper (Baxter's hand range sensor, a Sharp-style
// triangulating IR sensor). Defaults are typical of such sensors, not measured.
struct IrRangeOptions {
  double min_range = 0.04;  // m
  double max_range = 0.40;  // m
  bool noise = true;
  double sigma = 0.001;           // m, constant part of the reading noise
  double sigma_per_metre = 0.01;  // m per m of range
  void Validate() const;
};

// The scene of one hung garment: Embree device, the garment (+ gripper) in the object
// frame and the world-fixed background. Immutable after construction; all queries are
// const and thread-safe.
class SweepScene {
 public:
  // hung: the garment in the object frame (grasp at the origin, y up). Throws
  // drape::Error on bad options or an empty/non-finite mesh.
  SweepScene(const TriMesh& hung, const SweepOptions& options);
  ~SweepScene();
  SweepScene(const SweepScene&) = delete;
  SweepScene& operator=(const SweepScene&) = delete;

  const SweepOptions& options() const;
  // Pixels whose rays can hit the garment or the gripper at this gripper angle (the
  // projected box of the turned object-frame bounds); only these are cast per frame.
  PixelRect Roi(double angle) const;
  // Noise-free depth of the whole image at this gripper angle.
  ExactFrame RenderExact(double angle) const;
  void RenderExact(double angle, ExactFrame& frame) const;  // reuses frame's buffers
  // A Kinect frame (metres, 0 = no data) at this gripper angle with options().kinect's
  // noise drawn from rng; identical to ApplyKinectNoise(RenderExact(angle), ...), but the
  // noise plan of the static background is made once and only the region around the
  // garment is re-planned.
  // `scratch` (optional) keeps buffers between frames and receives the exact frame.
  std::vector<float> RenderKinect(double angle, Rng& rng, KinectScratch* scratch = nullptr) const;
  // Distance (m) along the unit direction `dir` from `origin` (world frame, garment at
  // gripper angle `angle`) to the first surface, or +infinity if none lies within
  // [min_range, max_range]. With rng and ir.noise: Gaussian reading noise
  // σ = sigma + sigma_per_metre·range.
  double RangeAlongRay(const Vec3& origin, const Vec3& dir, double angle = 0.0, const IrRangeOptions& ir = {},
                       Rng* rng = nullptr) const;
  // Object-frame bounds of the garment plus the gripper.
  Eigen::AlignedBox3d ObjectBounds() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Turns an exact frame into a Kinect reading (metres, 0 = no data) with the noise of
// `kinect` and random draws from rng (one 64-bit draw per pixel, raster order).
std::vector<float> ApplyKinectNoise(const ExactFrame& exact, const KinectOptions& kinect, Rng& rng);

KinectPlan PlanKinectNoise(const ExactFrame& exact, const KinectOptions& kinect);
// Re-plans the pixels of `region` (whole rows of it, scanning the shadow from its right
// edge). Exact if everything outside the region is as when it was planned and the region
// reaches ≥ b·f/z_min px left of any change (a shadow's widest extent).
void UpdateKinectPlan(const ExactFrame& exact, const KinectOptions& kinect, const PixelRect& region, KinectPlan& plan);
std::vector<float> DrawKinectNoise(const ExactFrame& exact, const KinectPlan& plan, const KinectOptions& kinect,
                                   Rng& rng, KinectScratch* scratch = nullptr);

// Renders the sweep; frame i's noise comes from Rng(DeriveSeed(seed, "frame/<i>")).
// Same inputs → identical frames for any thread count.
Sweep SimulateSweep(const TriMesh& hung_object_frame, const SweepOptions& options, uint64_t seed);

// Files of a sweep, deterministic bytes, paths relative to the entry folder:
//   sweep/000000.png ...   16-bit PNG depth, millimetres, 0 = no data
//   sweep/cameras.json     intrinsics, depth_scale 1000, per-frame 4×4 row-major
//                          camera_to_object / camera_to_world, gripper angle, options
//   sweep/trajectory.json  Open3D PinholeCameraTrajectory (extrinsic = object→camera)
//   sweep/depth.txt, sweep/groundtruth.txt   TUM RGB-D lists (timestamp file /
//                          timestamp tx ty tz qx qy qz qw of camera_to_object)
std::vector<std::pair<std::string, std::string>> EncodeSweep(const Sweep& sweep);
// Reads the folder holding cameras.json (depth comes back quantised to 1 mm).
Sweep ReadSweep(const std::filesystem::path& dir);
// One frame, TURBO colour map (near = red … far = blue, no data = black), with a
// colour bar in metres. PNG bytes.
std::string RenderDepthPreview(const DepthFrame& frame, const Intrinsics& intrinsics);

}  // namespace drape
