// Internal: the sparse block volume behind Tsdf, shared by tsdf.cpp (integration,
// queries; no OpenVDB) and vdb.cpp (OpenVDB meshing and .vdb export).
#pragma once

#include <array>
#include <atomic>
#include <cmath>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "generator/fusion/fusion.h"

namespace drape {

// 8³ voxels, the size of an OpenVDB leaf; voxel offset (x<<6)|(y<<3)|z like a leaf's.
constexpr int kBlockDim = 8;
constexpr int kBlockVoxels = kBlockDim * kBlockDim * kBlockDim;

struct FusionBlock {
  Eigen::Vector3i coord;  // block coordinate; voxel index = coord*8 + local
  std::array<float, kBlockVoxels> tsdf;
  std::array<float, kBlockVoxels> weight;
  int stamp = -1;  // last frame that touched it
};

inline int LocalOffset(int x, int y, int z) { return (x << 6) | (y << 3) | z; }

// One frame's pose and the pixel rectangle [u0, u1) × [v0, v1) that can matter: every
// voxel of a block the band can allocate, and every carving cell that can end up
// inside, projects into it (see RegionOfInterest in tsdf.cpp).
struct FrameView {
  int W = 0, H = 0;
  Intrinsics K;
  Eigen::Matrix3d R, Rt;  // camera → object rotation and its transpose
  Eigen::Vector3d t;      // camera centre in the object frame
  int u0 = 0, v0 = 0, u1 = 0, v1 = 0;
  // Carving cells considered this frame (carve-grid coordinates, inclusive).
  Eigen::Vector3i cell_lo{0, 0, 0}, cell_hi{-1, -1, -1};
};

// Per-frame image buffers, kept between frames (a 640×480 frame would otherwise cost
// a few MB of page faults each time). Values outside the frame's rectangle are stale.
struct FrameScratch {
  // code > 0: foreground depth; < 0: -depth of a point outside the box (carves free
  // space only); 0: background without data; NaN: no data next to the garment.
  std::vector<float> code;
  std::vector<uint8_t> fg;
  std::vector<int> runs, parent;  // non-foreground runs of the dropout labelling
  std::vector<uint8_t> edge, reaches;
  std::vector<uint64_t> near_bits, row_bits;  // MarkNearForeground's bit masks
  std::vector<uint64_t> seen;                 // band blocks already listed this frame: a bit per block-grid cell
  std::vector<double> band_xhat, band_d;      // a row's foreground samples (BandSamples)
  std::vector<int32_t> band_out;
  float far = 0;                                   // the largest foreground depth (0: none)
  int fg_u0 = 0, fg_u1 = 0, fg_v0 = 0, fg_v1 = 0;  // the foreground's bounding rectangle [u0, u1) × [v0, v1)
};

// One frame after its frame-local steps (segmentation, dropouts, the band's blocks),
// which depend on nothing but the frame: several frames are prepared at once, then
// applied to the volume in frame order (Tsdf::Impl::IntegrateBatch).
struct PreparedFrame {
  FrameView view;
  FrameScratch scratch;  // scratch.code: the segmented frame
  int64_t fg_count = 0;
  // The blocks the band crosses, each once, in the order the samples first reach them
  // (the order AllocateBand meets them: blocks are created in this order).
  std::vector<Eigen::Vector3i> band;
  std::vector<int> touched;                                // band's blocks' indices (Tsdf::Impl::blocks)
  double cpu_segment = 0, cpu_dropouts = 0, cpu_band = 0;  // thread CPU seconds (timing only)
};

// A block's voxel centres in the camera frame of one view: voxel (x, y, z) is at
// c0 + x·ex + y·ey + z·ez (floats, the order UpdateBlock* evaluates them in).
struct VoxelProjector {
  Eigen::Vector3f c0, ex, ey, ez;
  float fx = 0, fy = 0, cx = 0, cy = 0, mu = 0;
  int W = 0, H = 0;
};
VoxelProjector ProjectorFor(const FrameView& view, const Eigen::Vector3i& block, double h, double mu);
// Projective TSDF update of one block's voxels against `code` (FrameScratch::code
// semantics); returns the number of voxels updated. The scalar loop is the definition;
// the AVX2 and AVX-512 ones give the same bits (no FMA contraction, IEEE div/sqrt).
int64_t UpdateBlockScalar(FusionBlock& blk, const VoxelProjector& p, const float* code);
int64_t UpdateBlockAvx2(FusionBlock& blk, const VoxelProjector& p, const float* code);
int64_t UpdateBlockAvx512(FusionBlock& blk, const VoxelProjector& p, const float* code);
bool HaveAvx2();
bool HaveAvx512();

// One row of the segmentation: pixels [u0, u1) of a row (depth, code, fg point at the
// row's pixel 0, xhat per column, yv the row's ŷ): code and fg as FrameScratch says,
// for p = R·(d·x̂, d·ŷ, d) + t in the box [lo, hi] and within the radius (radius2 <= 0:
// none), the sums in the order Eigen evaluates the reference's `R * Vec3(x, y, z) + t`
// (SSE2: rows 0 and 1 as a packet, ((R₀x + R₁y) + R₂z) + t; row 2 by its unrolled
// reduction, (R₀x + (R₁y + R₂z)) + t; a test pins that). Returns the foreground count;
// *far = max(*far, the row's largest foreground depth). The AVX2 and AVX-512 ones give the same bits.
struct SegmentRow {
  const float* depth = nullptr;
  const double* xhat = nullptr;
  double yv = 0;
  double R[3][3] = {}, t[3] = {}, lo[3] = {}, hi[3] = {};
  double radius2 = 0;
  float* code = nullptr;
  uint8_t* fg = nullptr;
  mutable int fg_lo = 0, fg_hi = 0;  // columns [fg_lo, fg_hi) hold the foreground pixels seen (widened)
};
int64_t SegmentRowScalar(const SegmentRow& row, int u0, int u1, float* far);
int64_t SegmentRowAvx2(const SegmentRow& row, int u0, int u1, float* far);
int64_t SegmentRowAvx512(const SegmentRow& row, int u0, int u1, float* far);  // 8 at a time (AVX-512VL/BW)

// The band's samples of one row's foreground pixels (BandBlocks): pixel i (x̂ of its
// column xhat[i], depth d[i]; both arrays padded to a multiple of 8) has the samples
// z = d + along[k] / λ (k < samples, λ = √(1 + x̂² + ŷ²)) on its ray R·(x̂, ŷ, 1), in
// the object frame p = z·ray + t; each is rounded to its voxel (FloorVoxel) and block.
struct BandSamples {
  const double* xhat = nullptr;
  const double* d = nullptr;
  int n = 0;
  double yv = 0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Vec3 t = Vec3::Zero();
  const double* along = nullptr;
  int samples = 0;
  double h = 0, inv_h = 0;
  Eigen::Vector3i grid_lo{0, 0, 0}, grid_dims{0, 0, 0};  // Tsdf::Impl's block grid
};
// Sample k of pixel i by the definition (the Eigen expressions BandBlocks always used):
// false if z <= 0, else its block.
bool BandSampleBlockAt(const BandSamples& a, int i, int k, Eigen::Vector3i* b);
// out[(i / 8)·8·samples + 8k + i % 8] for pixel i < n, sample k: the grid index of the
// sample's block (Tsdf::Impl::GridIndex), -1 for no sample (z <= 0), -2 for a block off
// the grid, or (AVX-512 only) a voxel whose rounding the division decides: the caller
// takes those from BandSampleBlockAt. The AVX-512 one gives the scalar one's bits (same
// operations in the same order, Eigen's: the ray's rows 0 and 1 ((R₀x + R₁y) + R₂),
// row 2 (R₀x + (R₁y + R₂)); a test pins it). out holds 8·samples per 8 pixels.
void BandSamplesScalar(const BandSamples& a, int32_t* out);
void BandSamplesAvx512(const BandSamples& a, int32_t* out);
bool HaveAvx512VlBw();

// Space carving of one run of carving cells along z (CarveBlocks) in one view: cells
// (bx, by, bz), bz = bz0 + i for i < n, with their counts at view_count[i] and
// free_count[i]. Per cell, as the reference carves (tsdf_reference.cpp): a cell free in
// half of 16+ views is left alone; else its block centre p = (8b + 3.5)·h in the
// camera, c = Rt·(p - t), rounds to the pixel (floor(f c / c_z + c_0 + 0.5)); in front
// of the camera and on the image, the view counts; unless the pixel is NaN, it is
// free if no data (0) or (|d| - c_z)·|c|/c_z > μ (counts saturate at 65535).
struct CarveRun {
  double px = 0, py = 0;  // p.x, p.y of the run's cells
  int bz0 = 0, n = 0;     // absolute block z of cell 0, cells
  Eigen::Matrix3d Rt = Eigen::Matrix3d::Identity();
  Vec3 t = Vec3::Zero();
  double h = 0, mu = 0, fx = 0, fy = 0, cx = 0, cy = 0;
  int W = 0, H = 0;
  const float* code = nullptr;
  uint16_t* view_count = nullptr;
  uint16_t* free_count = nullptr;
};
// The scalar one is the definition; the AVX-512 one (8 cells at a time, doubles, the
// same operations in Eigen's order: c's rows 0 and 1 ((R₀x + R₁y) + R₂z), row 2
// (R₀x + (R₁y + R₂z)), |c|² = (x² + y²) + z²) gives the same counts.
void CarveRunScalar(const CarveRun& a);
void CarveRunAvx512(const CarveRun& a);

// MarkNearForeground's steps on a row of w pixels: fg bytes (0 / 1) to bits (pixel u at
// bit u % 64 of word u / 64, bits past w zero), and code → NaN where the bit is set
// and the code is 0 (no data). The AVX-512 ones (AVX-512VL/BW) give the same.
void PackRowBitsScalar(const uint8_t* fg, int w, uint64_t* bits);
void PackRowBitsAvx512(const uint8_t* fg, int w, uint64_t* bits);
void NanWhereNoDataScalar(const uint64_t* bits, int w, float* code);
void NanWhereNoDataAvx512(const uint64_t* bits, int w, float* code);

struct Tsdf::Impl {
  FusionOptions opt;
  double h = 0, mu = 0;

  std::unordered_map<uint64_t, int> index;  // packed block coord → blocks[i]
  std::vector<std::unique_ptr<FusionBlock>> blocks;
  // The same for the blocks of a grid over the carving grid grown by kGridMargin blocks
  // (every block the band can reach: foreground points lie in the box, the band within
  // μ <= 2 blocks of them): a flat array, -1 = not allocated. `index` holds every block.
  static constexpr int kGridMargin = 3;
  Eigen::Vector3i grid_lo{0, 0, 0}, grid_dims{0, 0, 0};
  std::vector<int32_t> grid;

  // Block-level carving grid over the segmentation box.
  Eigen::Vector3i carve_lo{0, 0, 0}, carve_dims{0, 0, 0};
  std::vector<uint16_t> free_count, view_count;

  int frames = 0;
  int64_t foreground_pixels = 0, voxel_updates = 0;
  std::vector<std::unique_ptr<PreparedFrame>> prepared;  // buffers of a batch, kept between batches
  FusionStats::Steps times;                              // accumulated wall time of each step
  FusionStats::Steps times_cpu;                          // and process CPU time

  // Cached ray directions for the last intrinsics.
  Intrinsics rays_for{};
  std::vector<double> xhat, yhat;
  bool rays_valid = false;

  // Completion (rules 2 and 3 of fusion.h), computed lazily after integration.
  mutable std::mutex complete_mutex;
  mutable std::atomic<bool> dirty{true};
  mutable std::vector<std::array<float, kBlockVoxels>> completed;  // per block
  mutable std::vector<uint8_t> has_observed;                       // per block
  mutable std::vector<uint8_t> inside;                             // per carve cell
  mutable int inside_blocks = 0, observed_voxels = 0;

  static uint64_t Key(const Eigen::Vector3i& b) {
    constexpr int64_t kOff = int64_t(1) << 20;
    return (uint64_t(b.x() + kOff) << 42) | (uint64_t(b.y() + kOff) << 21) | uint64_t(b.z() + kOff);
  }
  int CarveIndex(const Eigen::Vector3i& b) const {
    const Eigen::Vector3i r = b - carve_lo;
    if ((r.array() < 0).any() || (r.array() >= carve_dims.array()).any()) return -1;
    return (r.x() * carve_dims.y() + r.y()) * carve_dims.z() + r.z();
  }
  // Index of block b in `grid`, -1 outside it.
  int64_t GridIndex(const Eigen::Vector3i& b) const {
    const Eigen::Vector3i r = b - grid_lo;
    if ((r.array() < 0).any() || (r.array() >= grid_dims.array()).any()) return -1;
    return (int64_t(r.x()) * grid_dims.y() + r.y()) * grid_dims.z() + r.z();
  }
  int FindBlock(const Eigen::Vector3i& b) const {
    const int64_t g = GridIndex(b);
    if (g >= 0) return grid[g];
    auto it = index.find(Key(b));
    return it == index.end() ? -1 : it->second;
  }
  // The block's index, allocating it (zero values and weights) if new.
  int FindOrCreateBlock(const Eigen::Vector3i& b);

  // The steps of one Integrate (tsdf.cpp), in order. Frame-local steps (const, any
  // thread): MakeView, Segment, IgnoreDropouts (+ MarkNearForeground), BandBlocks; then,
  // on the volume in frame order: the band's blocks allocated, UpdateVoxels, CarveBlocks.
  FrameView MakeView(const Eigen::Isometry3d& camera_to_object, const Intrinsics& K) const;
  int64_t Segment(const float* depth, const FrameView& view, FrameScratch& s) const;
  void IgnoreDropouts(const FrameView& view, FrameScratch& s) const;
  void MarkNearForeground(const FrameView& view, FrameScratch& s) const;
  void BandBlocks(const FrameView& view, FrameScratch& s, std::vector<Eigen::Vector3i>& band) const;
  void Prepare(const float* depth, const Eigen::Isometry3d& camera_to_object, const Intrinsics& K,
               PreparedFrame& f) const;
  // Frames fused in order, frame-local steps of up to `prepared.size()` frames at once
  // on opt.threads threads, voxels block by block over those frames, carving cell by
  // cell: the same values as Integrate frame by frame for any thread count.
  struct FrameInput {
    const float* depth;
    Eigen::Isometry3d camera_to_object;
  };
  void IntegrateBatch(const std::vector<FrameInput>& inputs, const Intrinsics& K);
  void UpdateVoxels(const std::vector<PreparedFrame*>& batch);
  void CarveBlocks(const std::vector<PreparedFrame*>& batch);
  // The reference's band allocation (tsdf_reference.cpp): allocates the blocks the
  // band crosses and returns them in the order BandBlocks lists them.
  std::vector<int> AllocateBand(const FrameView& view, const std::vector<float>& code, int stamp);
  // The straightforward path (tsdf_reference.cpp): whole-image segmentation, flood
  // fill and carving, scalar voxel update; the same values bit for bit (a test checks).
  void IntegrateReference(const std::vector<float>& depth, const Eigen::Isometry3d& camera_to_object,
                          const Intrinsics& K);
  void UpdateRays(const Intrinsics& K);

  void EnsureComplete() const;
  // Completed value (metres) of voxel ijk.
  float VoxelValue(const Eigen::Vector3i& ijk) const;
};

inline int FloorDiv8(int v) { return v >= 0 ? v / 8 : -((-v + 7) / 8); }

// std::floor as an int without the libm call (no SSE4.1 in the baseline ISA); exact
// for |x| < 2^31.
inline int FloorInt(double x) {
  const int i = static_cast<int>(x);
  return x < i ? i - 1 : i;
}

// floor(x / h + 0.5), exactly as computed with the division, by a multiplication with
// inv_h = 1 / h: the two differ by < 6e-16·|q| (a few roundings), so where the product's
// fraction is more than 1e-9 from an integer (and |q| < 1e6) its floor is the
// division's; elsewhere (about 2 in 10⁹ samples) the division decides.
inline int FloorVoxel(double x, double h, double inv_h) {
  const double q = x * inv_h + 0.5;
  if (std::abs(q) < 1e6) {
    const int i = FloorInt(q);
    const double f = q - i;  // exact
    if (f > 1e-9 && f < 1 - 1e-9) return i;
  }
  return FloorInt(x / h + 0.5);
}

// The block of the voxel nearest a band sample p (object frame, metres).
inline Eigen::Vector3i BandSampleBlock(const Vec3& p, double h, double inv_h) {
  return {FloorDiv8(FloorVoxel(p.x(), h, inv_h)), FloorDiv8(FloorVoxel(p.y(), h, inv_h)),
          FloorDiv8(FloorVoxel(p.z(), h, inv_h))};
}

}  // namespace drape
