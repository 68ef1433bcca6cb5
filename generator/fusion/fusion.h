// Segmentation by a 3D box and KinectFusion-style TSDF fusion of a depth sweep of a
// garment turning on the gripper (paper §"3D Reconstruction"), mesh extraction,
// .vdb export and reconstruction-accuracy metrics.
//
// Everything is in the OBJECT frame of the hung garment: grasp point at the origin,
// y up, garment hanging below (y < 0). Depth frames carry camera_to_object poses, so
// the turning garment fuses like a static scene.
//
// Signed distance convention (the paper's): Sdf(p) < 0 inside the observed surface,
// > 0 outside, 0 on it, in metres, truncated to [-truncation, +truncation].
// Sdf(p) is defined as follows (voxel centres at integer multiples of the voxel size
// h = 1/voxels_per_metre; values between centres are trilinear):
//   1. voxels observed (fusion weight >= min_weight; observations = band updates
//      and free-space updates in front of an observed depth) hold the weighted running
//      average of the projective truncated distance (see Tsdf::Integrate);
//   2. an unobserved voxel inside a block of 8³ voxels that holds observed voxels takes
//      ±truncation with the sign of the nearest observed voxel of its block (so the
//      deep side of a surface reads inside, the far-in-front side outside);
//   3. any other voxel takes the state of its block, recorded by space carving: a
//      block whose centre was seen as free space in at least `carve_min_views` frames
//      (in front of an observed depth by more than the truncation, or on a
//      background pixel with no data) in enough frames (carve_min_views,
//      carve_min_fraction) is OUTSIDE (+truncation); a block not carved,
//      seen by at least one frame, inside the segmentation box and inside the bounds
//      of the observed surface blocks (the "carved hull") is INSIDE (-truncation);
//      everything else (outside the box, never in view) is outside.
// So the interior of a closed or nearly closed garment (between the front and back
// layers of a shirt, inside a trouser leg), which no camera ray ever reaches, reads
// inside, like a visual hull; the gap between two layers ~1 cm apart lies within the
// band behind both layers and reads inside too.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/mesh.h"

namespace drape {

struct FusionOptions {
  // Voxel density (paper: 384 voxels per metre, X = 384, Y = Z = 768 voxels).
  double voxels_per_metre = 384;
  // Truncation distance μ in metres; <= 0 means 4 voxels (≈ 1.04 cm at 384/m).
  // Why 4 voxels: large enough to average Kinect noise at ~1–1.5 m (σ_z ≈ 2–4 mm)
  // and disparity steps (~5 mm), small enough that the band behind the front layer
  // of a two-layer garment (layers ~1 cm apart) does not reach past the back layer
  // (a voxel just behind the back layer is > μ behind the front one and is left to
  // the views that see it from the other side).
  double truncation = 0;
  // Segmentation region in the object frame (paper: a 2D box plus a depth range, one
  // box for the whole set-up): a pixel is foreground iff its back-projected point lies
  // in `box` and within `radius` of the turning (y) axis. The radius makes the region
  // a world-fixed cylinder as the garment turns (a box turning with the garment would
  // sweep its corners 0.85 m out and catch the sweep scene's table at 0.63 m).
  // Defaults, for the sweep's set-up (gripper 1.5 m above the floor): x, z ∈ [-0.6,
  // 0.6] m, radius 0.55 m, y ∈ [-1.45, -0.02] m — the space under the gripper that a
  // garment up to 1.45 m long hangs in, excluding the gripper's fingers (down to
  // y = -0.015), the arm, the table, the wall and the floor (y = -1.5).
  // Pixels outside the region still carve free space in front of them.
  Eigen::AlignedBox3d box{Eigen::Vector3d(-0.6, -1.45, -0.6), Eigen::Vector3d(0.6, -0.02, 0.6)};
  double radius = 0.55;  // metres; <= 0: no radial limit
  // A voxel counts as observed (rule 1 below) once it has this many observations;
  // fewer (a stray noisy pixel allocating a block that no other frame touches) leave
  // it to rules 2 and 3, so isolated speckles do not become floating surfaces.
  int min_weight = 3;
  // A block is carved (outside) once seen as free space in at least carve_min_views
  // frames and in at least carve_min_fraction of the frames that see it: Kinect
  // dropouts (grazing angles, edges, projector shadows) over a 300-frame sweep would
  // otherwise carve the interior of thin parts (measured: 12 % of the mesh vertices
  // were interior bubbles). Outside space near a garment is seen free in most views.
  int carve_min_views = 2;
  double carve_min_fraction = 0.1;
  // A pixel with no data counts as background (free space) only if it is connected to
  // the image border through non-foreground pixels and no foreground pixel lies within
  // this many pixels (Chebyshev distance); others are dropouts on the garment, ignored.
  int hole_radius_px = 1;
  // FuseFrames uses every k-th frame. Default 3: a 300-frame sweep turns 1.2° per
  // frame, and every 3rd frame (100 frames, 3.6° apart) gives nearly the same result
  // (measured on a 300-frame Embree Kinect sweep of a garment-sized object: recon→truth
  // mean / p95 1.18 / 5.4 mm with all frames, 1.25 / 6.0 mm with every 3rd) at a third
  // of the cost (~25 ms per 640×480 frame on one loaded core: 8.0 s → 2.5 s).
  int frames_stride = 3;
  // Simulated gripper-encoder error: each frame's rotation about the gripper (y) axis
  // is perturbed by N(0, σ) degrees, seeded from FuseFrames' seed. 0 = exact poses.
  double pose_noise_degrees = 0;
  // Threads of the fusion (results identical for any count; <= 0: all cores): the
  // frame-local steps (segmentation, dropouts, the band's blocks) of up to 8 frames at
  // once, then the voxels block by block and the carving cells slab by slab over those
  // frames, and the completion block by block.
  int threads = 1;

  double VoxelSize() const { return 1.0 / voxels_per_metre; }
  double Truncation() const { return truncation > 0 ? truncation : 4.0 / voxels_per_metre; }
  void Validate() const;  // throws drape::Error naming the bad field
};

struct FusionStats {
  int frames_integrated = 0;
  int64_t foreground_pixels = 0;  // summed over frames
  int64_t voxel_updates = 0;      // summed over frames
  int surface_blocks = 0;         // allocated 8³ blocks
  int observed_voxels = 0;        // voxels with weight > 0
  int inside_blocks = 0;          // unallocated blocks classified inside (unobserved interior)
  int mesh_vertices = 0, mesh_faces = 0;
  double wall_seconds = 0;  // timing only, never hashed
  // Wall seconds of Integrate's steps summed over frames (timing only, never hashed).
  struct Steps {
    double segment = 0, dropouts = 0, allocate = 0, update = 0, carve = 0;
  } steps;
  // The same in CPU seconds of the whole process (all threads; timing only): on a shared
  // machine the figure to compare across runs.
  Steps steps_cpu;
};

// A sparse TSDF volume: 8³-voxel blocks in a hash (only the band near the observed
// surface is allocated and touched per frame) plus a block-level space-carving grid
// over the segmentation box. Not copyable; const methods are safe to call from
// several threads.
class Tsdf {
 public:
  explicit Tsdf(const FusionOptions& options);
  ~Tsdf();
  Tsdf(const Tsdf&) = delete;
  Tsdf& operator=(const Tsdf&) = delete;

  // Fuses one frame with its camera_to_object pose. Pixels whose back-projected point
  // falls in the box are surface samples; for each, the blocks along the ray within
  // ±μ of the depth are allocated; every voxel of those blocks is projected into the
  // image and updated with the projective distance sdf = (d - z)·|ray|/z_ray along
  // the pixel's ray (KinectFusion), clamped to +μ, skipped below -μ; weights count
  // observations (weighted running average).
  // Throws drape::Error if the frame's size does not match the intrinsics.
  void Integrate(const DepthFrame& frame, const Intrinsics& intrinsics);
  // The same update by the straightforward path (whole image, scalar; slower): the
  // reference the fast path is tested against — identical values, mesh and .vdb bytes.
  void IntegrateReference(const DepthFrame& frame, const Intrinsics& intrinsics);

  // Signed distance at p (object frame, metres), as defined at the top of this file.
  double Sdf(const Vec3& p) const;
  // Fusion weight (number of observations) of the voxel nearest p; 0 if unobserved.
  double Weight(const Vec3& p) const;

  // Zero level set by OpenVDB's volumeToMesh (quads split into triangles), object
  // frame, triangles counter-clockwise seen from outside. Closed wherever the field is.
  TriMesh ExtractMesh() const;
  // The zero crossings of the completed field along voxel edges (where a marching-cubes
  // mesh puts its vertices), object frame, metres: one point per edge between voxel
  // centres whose values differ in sign (< 0 vs >= 0), linearly interpolated. Edges
  // touching a surface block or an unobserved-interior block are considered (elsewhere
  // the field is +μ everywhere). What the feature needs from the surface (its extent,
  // the top layer's centre, the largest radius) without meshing (recognition_bench, 384
  // voxels/m: 77 CPU-ms against ExtractMesh's 280). Deterministic order.
  Points3 SurfacePoints() const;
  // Bytes of a .vdb file with two FloatGrids: "sdf" (level set class, background
  // +μ, active = observed voxels, unobserved interior as inactive -μ tiles/voxels) and
  // "weight" (background 0), both with a linear transform of the voxel size (index
  // (i,j,k) ↔ object-frame point (i,j,k)·h). Deterministic bytes (the file's random
  // UUID is replaced by one derived from the content).
  std::string EncodeVdb() const;

  const FusionOptions& options() const;
  FusionStats Stats() const;  // counts so far (no mesh counts, no timing)

  struct Impl;

 private:
  friend struct FusionResult FuseFrames(const std::vector<DepthFrame>&, const Intrinsics&, const FusionOptions&,
                                        uint64_t, bool);
  std::unique_ptr<Impl> impl_;
};

struct FusionResult {
  std::shared_ptr<Tsdf> tsdf;
  TriMesh mesh;
  FusionStats stats;
};

// Fuses frames[0], frames[stride], ... in order (pose noise drawn per frame index from
// DeriveSeed(seed, "fusion/pose")) and extracts the mesh (extract_mesh = false: the mesh
// is left empty, e.g. for a query whose feature takes Tsdf::SurfacePoints).
FusionResult FuseFrames(const std::vector<DepthFrame>& frames, const Intrinsics& intrinsics,
                        const FusionOptions& options, uint64_t seed, bool extract_mesh = true);

// Reconstruction accuracy, metres. Points are sampled on each mesh (area-weighted,
// `samples` per mesh, a fixed seed: deterministic) and their distances to the other
// mesh's surface measured exactly (Embree point queries + closest point on triangle).
// recon→truth = accuracy, truth→recon = completeness. p95 = nearest-rank 95th percentile.
struct Accuracy {
  double recon_to_truth_mean = 0, recon_to_truth_p95 = 0;
  double truth_to_recon_mean = 0, truth_to_recon_p95 = 0;
};
Accuracy MeasureAccuracy(const TriMesh& recon, const TriMesh& truth, int samples = 20000);

// Area-weighted deterministic surface samples (#samples×3), used by MeasureAccuracy.
Points3 SampleSurface(const TriMesh& mesh, int samples, uint64_t seed);
// Distance from each point to the closest point of the mesh surface (Embree BVH).
std::vector<double> PointToMeshDistances(const Points3& points, const TriMesh& mesh);

}  // namespace drape
