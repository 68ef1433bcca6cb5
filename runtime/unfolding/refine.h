// Local refinement of a regrasp point with the IR range sensor (paper §"Grasping Point
// Localization" and §"Search for Best Grasping Point by Local Curvature"): the gripper
// scans horizontally across the predicted point, the 1-D range signal is convolved with
// the Laplacian-of-Gaussian kernel
//
//   g''(x) = (x²/σ⁴ − 1/σ²) · exp(−x²/(2σ²)),
//
// and the grasp goes where the response is lowest: a fold standing out towards the
// gripper, as wide as the gripper's opening, is what it can pinch.
//
// Where it looks. The scan runs ±10 cm so the filter sees the surface around the
// prediction, but the grasp moves only to a local minimum of the response within half the
// gripper's opening (±4 cm) of the prediction; with none there it stays at the prediction.
// Taking the lowest response of the whole scan, as first built, went to the nearest ridge
// crest up to 9 cm sideways (a sleeve's or leg's side fold): on the paper release the
// grasp ended farther from the target anchor than the prediction in 37 of 57 steps, while
// jaws centred on the prediction already close on everything within ±4 cm of it.
//
// Units. The paper gives σ = 10 for a gripper opening of ≈ 8 cm without units; here x is
// the sample index along the scan and σ = 10 samples, with samples 4 mm apart, so σ is
// 4 cm and the kernel's negative lobe (|x| < σ) spans 8 cm, the gripper's opening.
// Signal. The sensor reads a range r (metres, larger = farther). We convolve the
// surface's height towards the sensor, h = −r: at the crest of a ridge h has a maximum,
// h'' < 0, and (h ∗ g'') = (h'' ∗ Gaussian) is at its minimum there — the paper's
// "lowest point is where the gripper should grasp".
#pragma once

#include <vector>

#include "common/mesh.h"

namespace drape::unfolding {

struct RefineOptions {
  double sigma_samples = 10;      // σ of g'' in samples (paper: 10)
  double sample_spacing = 0.004;  // m between IR readings along the scan
  int half_width_samples = 25;    // scan from −25 to +25 samples: ±10 cm around the prediction
  // The grasp moves at most this many samples from the scan's centre (10: ±4 cm, half the
  // gripper's 8 cm opening); must be in 0..half_width_samples.
  int search_half_width_samples = 10;
  // The grasp depth from the nearest reading within this many samples of the chosen one
  // (0: its own reading). The jaws span ±4 cm across the scan and close on the nearest
  // cloth between them: a beam that passes a sleeve's edge and reads the body 16 cm behind
  // must not send them there (LoopOptions::hanging_end). Must be in 0..half_width_samples.
  int depth_half_width_samples = 0;
  void Validate() const;  // throws drape::Error naming the bad field
};

// g''(x) sampled at x = −radius … radius (2·radius + 1 values), radius = ⌈4σ⌉.
std::vector<double> LaplacianOfGaussian(double sigma);

// (signal ∗ kernel)[i] = Σ_k signal[i − k + r]·kernel[k] with the kernel centred
// (r = kernel.size()/2) and the signal extended by its end values (no edge artefacts
// from zero padding). Same length as signal.
std::vector<double> Convolve(const std::vector<double>& signal, const std::vector<double>& kernel);

// Missing readings (nothing within the sensor's range: off the garment's edge) take the
// nearest valid reading, so running off the cloth reads as more of the same surface
// rather than as a deep step, whose edge the filter would otherwise take for a fold.
struct RefineResult {
  bool valid = false;            // at least one reading
  std::vector<double> height;    // −range per sample, m (missing readings filled as above)
  std::vector<double> response;  // height ∗ g''
  int best = -1;                 // lowest local minimum of the response within the search
                                 // window, else the centre sample
  bool fold_found = false;       // best is such a local minimum (false: prediction kept)
  double offset = 0;             // m along the scan from its centre to the best sample
  double range = 0;              // m, the (filled) reading at the best sample, or the nearest
                                 // within depth_half_width_samples of it
  bool measured = false;         // the best sample has a reading of its own (not filled)
};

// ranges: readings in scan order, centred on the predicted point, +inf or ≤ 0 = none.
// Throws drape::Error on an empty scan; with no reading at all, valid = false and best
// is the centre.
RefineResult RefineScan(const std::vector<double>& ranges, const RefineOptions& options);

// Where the free gripper scans and where it closes (world frame, m). The gripper faces
// `approach` (unit, used as given), its fingers close along `closing` (unit, ⊥ approach); the IR sensor
// sits at `mount` in the gripper frame (x = closing, y = approach × closing, z = approach;
// hardware::RangeSensor::mount), so its beam runs along the approach at mount.x, mount.y
// off the jaw centre.
//
// The scan runs across the predicted point `standoff` before it along the approach; the
// grasp goes to the surface the beam saw at the chosen sample, `grasp_depth` past it.
// With `at_jaw_line` (default) the jaw centre scans mount.x, mount.y off the line through
// the prediction so that the beam crosses the prediction: the sensor reads the cloth where
// the jaws will close. Without it (as first built) the jaw centre scans through the
// prediction and the beam, 3 cm above the jaws on the simulated hand, reads cloth 3 cm
// above where the jaws close: under a fold or above a leg's end that is other cloth, and
// the jaws stopped short of the target (on the paper release 6.4–7.6 cm short of a
// prediction 1–2 cm from the anchor: two misses in a row).
struct IrScanPlan {
  Vec3 predicted = Vec3::Zero();
  Vec3 approach = Vec3::UnitZ();
  Vec3 closing = Vec3::UnitX();
  Vec3 mount = Vec3::Zero();
  double standoff = 0.12;
  double grasp_depth = 0.01;
  bool at_jaw_line = true;
  // The jaw centre while the sensor reads at `offset` (m along the closing direction from
  // the scan's centre).
  Vec3 JawDuringScan(double offset) const;
  // The jaw centre to close at: the point the beam hit at the best sample of `r`, plus
  // grasp_depth along the approach (along the beam's line through the jaw line either way:
  // the grasp does not rise to where the beam ran when at_jaw_line is false).
  Vec3 Grasp(const RefineResult& r) const;
  // The same with the beam line `up` higher (up = approach × closing, the gripper's y
  // axis): a vertical scan through the chosen sample (FindLowerEdge), and a grasp at the
  // surface the beam saw at `range` there.
  Vec3 JawDuringScan(double offset, double up) const;
  Vec3 Grasp(double offset, double up, double range) const;
};

// The cloth's lower edge below a regrasp point (`--hem-edge`, LoopOptions::hem_edge).
//
// The desired anchors of pants and shorts are leg ends: corners of a hem, the lowest
// cloth of a leg hanging free. Registration puts them 5-9 cm off, much of it along the
// leg (the database hang and the test hang differ in length), and the horizontal LoG
// scan does not look up or down. When the registered database mesh has its target at the
// bottom of the cloth around it (`AnchorAtLowerEdge`), the gripper also scans
// vertically through the refined point, top to bottom, and the jaws close `inset` above
// the lowest sample of the surface the refined point lies on: the hem, seen by the beam
// as the last reading before it jumps to farther cloth or to nothing.
struct EdgeOptions {
  double sample_spacing = 0.004;  // m between readings of the vertical scan
  int above_samples = 25;         // scan from 10 cm above the refined point ...
  int below_samples = 37;         // ... to 14.8 cm below it
  double near = 0.04;             // m: a reading within this of the reference range is the surface
  double jump = 0.02;             // m: consecutive readings further apart than this are not one surface
  double inset = 0.01;            // m: the jaw centre goes this far above the edge (jaws 2 cm tall)
  // Whether the surface may be picked up above the refined point (as first built): the
  // nearest surface sample either way. false (default): at or below it only. On paper
  // 2.3.0 (seed 1) the prediction sat above the target leg end in 34 of 35 steps (shorts
  // 6.5 cm median at the last step), and a surface found only above the refined point was
  // a fold's or another layer's lower edge: the grasp went up 5-8 cm, away from the leg end.
  bool look_above = false;
  // AnchorAtLowerEdge: the anchor is at the lower edge when at most `below_fraction` of the
  // registered vertices within `radius` of it lie more than `below_margin` under it.
  double radius = 0.05, below_margin = 0.01, below_fraction = 0.25;
  // The hem's corner (`--hem-corner`): a horizontal scan at the jaws' new height, the jaw
  // centre `side_inset` in from the end of the surface on the side CornerSide names (jaws
  // 8 cm wide: 2 cm of air beyond the corner, 6 cm of hem). CornerSide: the cloth within
  // `side_radius` of the registered anchor lies, on average, more than `side_margin` to
  // one side along the closing direction.
  double side_inset = 0.02, side_radius = 0.08, side_margin = 0.015;
  void Validate() const;  // throws drape::Error naming the bad field
};

struct EdgeResult {
  bool found = false;  // a surface run through the reference that ends inside the scan
  int start = -1;      // the run's sample nearest the refined point (-1: no surface reading)
  int edge = -1;       // its lowest sample (found only)
  int grasp = -1;      // the sample `inset` above the edge (the jaws' height), a surface reading
  double up = 0;       // m from the refined point to the grasp sample (negative: down)
  double range = 0;    // m, the reading at the grasp sample
};

// ranges: readings top to bottom, sample i at height (above_samples − i) · spacing over
// the refined point; +inf or <= 0 = none. reference: the range the refined point was read
// at (the surface to follow); a surface sample reads within `near` of it. The run is the
// contiguous surface samples (consecutive readings within `jump`) through the surface
// sample nearest the refined point at or below it (either way with look_above); its lowest
// sample is the edge unless the run reaches the scan's bottom (the edge is farther down:
// not found). Throws drape::Error when the
// scan's length is not above_samples + below_samples + 1.
EdgeResult FindLowerEdge(const std::vector<double>& ranges, double reference, const EdgeOptions& options);

// The hem's end along a horizontal scan at the jaws' height (readings in scan order along
// the closing direction, sample i at (i − n/2) · spacing; n odd): the surface run through
// the sample nearest the centre reading within `near` of `reference`, its end on the side
// `toward` (−1: lower indices, +1: higher) if that end lies inside the scan, and the grasp
// sample `side_inset` in from it (within the run).
struct SideResult {
  bool found = false;
  int start = -1, edge = -1, grasp = -1;
  double offset = 0;  // m along the scan from its centre to the grasp sample
  double range = 0;   // m, the reading there
};
SideResult FindSideEdge(const std::vector<double>& ranges, double reference, int toward, double spacing,
                        const EdgeOptions& options);

// Which way along `closing` (unit, in `mesh`'s frame) the cloth ends at vertex `v`: −1
// when the cloth within side_radius lies on average more than side_margin towards
// +closing (the corner is the surface's −closing end), +1 the other way, 0 neither (the
// cloth around is centred on it, or the hem is seen edge-on).
int CornerSide(const TriMesh& mesh, int v, const Vec3& closing, const EdgeOptions& options);

// Whether vertex `v` of `mesh` (y up) lies at the bottom of the cloth around it (see
// EdgeOptions): what the registered database hang says of the target before any scan.
bool AnchorAtLowerEdge(const TriMesh& mesh, int v, const EdgeOptions& options);

}  // namespace drape::unfolding
