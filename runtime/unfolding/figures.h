// Pictures of an unfolding trial that a person can follow: the pick-up point on the
// pattern, per step the reconstruction with the predicted (red) and refined (green)
// regrasp points, the matched database mesh registered onto it and coloured by the
// objective's score (blue low … red high), the IR signal and its LoG-filtered curve, and
// the final grasp on the pattern next to the garment as the grippers hold it.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "garments/garment.h"
#include "runtime/unfolding/loop.h"

namespace drape::unfolding {

// Writes pickup.png, step_<k>.png (k = 1, 2, …) and final.png into dir; returns the
// file names written. Deterministic pixels.
std::vector<std::string> WriteTrialFigures(const TrialResult& trial, const Garment& test_garment, double sensing_height,
                                           const std::filesystem::path& dir);

}  // namespace drape::unfolding
