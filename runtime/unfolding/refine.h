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
// `approach` (unit, used as given), its fingers close along `closing` (unit, ⊥ approach);
// the IR sensor sits at `mount` in the gripper frame (x = closing, y = approach × closing,
// z = approach; hardware::RangeSensor::mount), so its beam runs along the approach at
// mount.x, mount.y off the jaw centre.
//
// The scan runs across the predicted point `standoff` before it along the approach, the
// jaw centre mount.x, mount.y off the line through the prediction so that the beam
// crosses the prediction: the sensor reads the cloth where the jaws will close. The grasp
// goes to the surface the beam saw at the chosen sample, `grasp_depth` past it. (With the
// jaw centre on the prediction's line, as first built, the beam read cloth 3 cm above
// where the jaws closed, and on the paper release they stopped 6.4–7.6 cm short of a
// prediction 1–2 cm from the anchor: two misses in a row.)
struct IrScanPlan {
  Vec3 predicted = Vec3::Zero();
  Vec3 approach = Vec3::UnitZ();
  Vec3 closing = Vec3::UnitX();
  Vec3 mount = Vec3::Zero();
  double standoff = 0.12;
  double grasp_depth = 0.01;
  // The jaw centre while the sensor reads at `offset` (m along the closing direction from
  // the scan's centre).
  Vec3 JawDuringScan(double offset) const;
  // The jaw centre to close at: the point the beam hit at the best sample of `r`, plus
  // grasp_depth along the approach.
  Vec3 Grasp(const RefineResult& r) const;
};

}  // namespace drape::unfolding
