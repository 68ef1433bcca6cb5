// Pictures of folding runs: key frames per step (like the paper's Fig.
// "good_examples"), the result's outline against the target's (the paper's flowchart:
// light blue result, black template), and the solution-space fan (Fig.
// "solution_space": 13 trajectories of one step coloured by the dissimilarity they end
// with, projected onto the vertical plane through P0 and P3).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "runtime/folding/run.h"

namespace drape::folding {

// One row: the cloth seen obliquely from the front-above at each kept frame of the
// step's optimised simulation, then the top-down outlines of result and target.
cv::Mat StepKeyFrames(const StepRecord& step, const Faces& F, int tile = 240);

// The settled flat garment as the camera above the table sees it, its mask outline
// and the key points found on it (red, named), with a caption: what a trial saw when
// its plan stopped before the first fold (e.g. a key point it could not find).
cv::Mat FlatGarmentFigure(const PlanRun& run, const Faces& F, const std::string& caption);

// What the success criterion judges, from above: the final shape (shaded), the ideal
// chained folds' outline (black) and that outline grown by `tolerance` (grey), with a
// caption.
cv::Mat ResultFigure(const PlanRun& run, const Faces& F, double tolerance, const std::string& caption);

// A fan of trajectories for one step: "symmetric" (both knots at height h·s for 13
// values of h), "early" (the first knot varies, the second at h = ⅓), "late" (the
// second varies).
struct FanTrajectory {
  CubicBezier path;
  double h = 0;              // the varied knots' height, × span
  double dissimilarity = 0;  // m; NaN when the simulation failed
};
std::vector<FanTrajectory> SolutionFan(const FoldScene& scene, const StepSetup& setup, const FoldSimOptions& sim,
                                       const std::string& kind, int count = 13);

// The fans side by side, each projected onto (distance along P0→P3, height), coloured
// by D on one shared scale, with S and T marked and a colour bar.
cv::Mat FanFigure(const std::vector<std::vector<FanTrajectory>>& fans, const std::vector<std::string>& titles);

}  // namespace drape::folding
