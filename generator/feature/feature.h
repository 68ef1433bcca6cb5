// The cylindrical binary shape feature of the paper (Algorithm 1) and its
// rotation-invariant Hamming matching (Eq. match). No OpenVDB here: the SDF comes in
// as a function, so the runtime links this cheaply.
//
// Geometry (object frame: grasp point at the origin, y up, garment below):
//   - layers: the y extent [y_min, y_max] of the surface points cut into N equal
//     slabs top-down; layer l spans y ∈ [y_max − (l+1)·H/N, y_max − l·H/N], H = y_max − y_min;
//   - polar origin (ox, oz) = mean (x, z) of the points in layer 0 (the gripper's layer),
//     as Algorithm 1; or, with FeatureOptions::origin "grip", (0, 0): the gripper's
//     vertical axis;
//   - r_m = the largest distance in the x–z plane from the origin over all points;
//     ring r spans radii [r·r_m/R, (r+1)·r_m/R) (uniform, not logarithmic);
//   - sector s spans angles φ ∈ [2πs/Φ, 2π(s+1)/Φ) with φ = atan2(−(z − oz), x − ox):
//     0 along +x, π/2 along −z, so φ grows with a right-handed (counter-clockwise seen
//     from above, +y) rotation about +y;
//   - bit (l, r, s) = 1 iff sdf(cell centre) ≤ 0, the centre being at height
//     y_max − (l+½)·H/N, radius (r+½)·r_m/R, angle (s+½)·2π/Φ.
// Bit order: index (l·R + r)·Φ + s, stored little-endian in uint64 words (bit i in
// words[i / 64] at position i % 64); unused high bits of the last word are 0.
// Rotating the garment by k·2π/Φ about the y axis (through the grasp point) turns
// bit (l, r, s) into bit (l, r, (s + k) mod Φ): Rotate(f, k).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "common/mesh.h"

namespace drape {

struct FeatureOptions {
  int layers = 16;   // N
  int rings = 16;    // R
  int sectors = 16;  // Φ, 1..64
  // The polar axis: "top_layer" (Algorithm 1: the mean (x, z) of the top layer's points)
  // or "grip" (x = z = 0, the gripper's vertical axis, known from the robot). The top
  // layer's mean moves with how the cloth falls around the jaws, and every ring with it.
  std::string origin = "top_layer";
  void Validate() const;  // throws drape::Error naming the bad field
};

struct Feature {
  int layers = 0, rings = 0, sectors = 0;
  std::vector<uint64_t> words;

  int NumBits() const { return layers * rings * sectors; }
  int NumWords() const { return (NumBits() + 63) / 64; }
  static int Index(int l, int r, int s, int rings, int sectors) { return (l * rings + r) * sectors + s; }
  bool Get(int l, int r, int s) const;
  void Set(int l, int r, int s, bool value);
  // Bit `bit` = Index(l, r, s) (no range check: the matcher's inner loops use these).
  bool Get(int bit) const { return (words[bit >> 6] >> (bit & 63)) & 1u; }
  void Set(int bit, bool value);
  int PopCount() const;
  bool SameShape(const Feature& o) const { return layers == o.layers && rings == o.rings && sectors == o.sectors; }
  // Throws drape::Error starting with `where` if the shape is outside FeatureOptions'
  // ranges or the words do not fit it (count, non-zero padding bits).
  void Check(const std::string& where) const;
  bool operator==(const Feature& o) const = default;
};

// All-zero feature of the given shape.
Feature ZeroFeature(int layers, int rings, int sectors);

// Signed distance in metres, ≤ 0 inside (Tsdf::Sdf or an analytic function).
using SdfFunction = std::function<double(const Vec3&)>;

// Algorithm 1. surface_points: #P×3, e.g. the reconstructed mesh's vertices (P ≥ 1,
// with a non-zero y extent). Throws drape::Error on bad input.
Feature ExtractFeature(const Points3& surface_points, const SdfFunction& sdf, const FeatureOptions& options);

// The cell centre of bit (l, r, s) for the given points (as ExtractFeature uses).
struct FeatureFrame {
  double y_max = 0, layer_height = 0, origin_x = 0, origin_z = 0, r_max = 0;
};
FeatureFrame ComputeFeatureFrame(const Points3& surface_points, const FeatureOptions& options);
Vec3 CellCentre(const FeatureFrame& frame, const FeatureOptions& options, int l, int r, int s);

// Eq. match: min over k in [0, Φ) of popcount(Rotate(a, k) XOR b). rotation = the
// smallest k reaching the minimum: b looks like a turned by k·2π/Φ.
// Throws drape::Error if the shapes (N, R, Φ) differ.
struct Match {
  int distance = 0;
  int rotation = 0;
};
Match Distance(const Feature& a, const Feature& b);           // word-parallel
Match DistanceReference(const Feature& a, const Feature& b);  // bit by bit
// Per-ring circular shift: out(l, r, (s + k) mod Φ) = f(l, r, s). Any integer k.
Feature Rotate(const Feature& f, int k);
// The feature of the garment's mirror image through a vertical plane (z → −z about the
// polar origin; any other vertical plane is this and a turn): per ring, sector s ↔ Φ − 1 − s. Exact, since the cell
// centres sit at the sectors' middles and the frame (layers, origin, r_m) is mirror-invariant. Eq. match turns but
// never mirrors, so a hang and its mirror image are different codes; a garment's left/right twin anchor hangs as the
// mirror image of the other's hang.
Feature Mirror(const Feature& f);
// Where bit `bit` goes under Rotate(·, k) for Φ = sectors.
int RotatedBit(int bit, int sectors, int k);

// Binary format (little-endian), 24 + 8·W bytes:
//   "DRFT" | u32 version = 1 | u32 N | u32 R | u32 Φ | u32 W = ceil(N·R·Φ / 64) | W × u64
std::string EncodeFeature(const Feature& f);
// Validates magic, version, shape, size and zero padding; throws drape::Error whose
// message starts with `where` (e.g. "entries/x/feature.bin").
Feature DecodeFeature(std::string_view bytes, const std::string& where);

}  // namespace drape
