// folding_bench: what trajectory optimisation with the cloth simulation in the loop
// costs — one simulated fold step (grasp, move along the initial h = 1/3 Bézier,
// release, settle) and one optimisation of that step (number of simulations, seconds),
// for a towel folded in half at three mesh sizes (how it scales with the node count).
// A main that prints a table (wall-clock; run it on a quiet machine).
// Usage: folding_bench [MAX_SIMS [EDGE ...]]: MAX_SIMS 0 times the simulated step only
// (no optimisation); edges in metres (default 0.06 0.045 0.035).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "garments/templates.h"
#include "runtime/folding/evaluate.h"

using namespace drape;
using namespace drape::folding;

int main(int argc, char** argv) {
  const int max_sims = argc > 1 ? std::atoi(argv[1]) : 40;
  std::vector<double> edges;
  for (int i = 2; i < argc; ++i) edges.push_back(std::atof(argv[i]));
  if (edges.empty()) edges = {0.06, 0.045, 0.035};
  std::printf("%-8s %6s %6s | %-28s | %-40s\n", "edge", "nodes", "faces", "one simulated step", "one optimisation");
  for (double edge : edges) {
    FoldSetup setup;
    TemplateOptions t;
    t.edge_length = edge;
    setup.garment = MakeGarment("towel", t);
    // towel_b as drape fold fits it at 6 cm edges (kLST 0.078, μ 0.409 on the tilted table).
    setup.material.link_stiffness = 0.078;
    setup.material.area_density = 0.35;
    setup.material.max_strain = 0.056;  // 1.8 × the 3.1 % stretch
    setup.material.bending = 0.02;
    setup.friction = 0.409;
    const FoldScene scene = MakeScene(setup);
    const Points3 flat =
        SettleFlat(scene, tabletop::LayFlat(setup.garment.mesh, setup.table), SettleOptions{0.002, 0.2, 0.3, 3});
    const Vec3 lo = flat.colwise().minCoeff(), hi = flat.colwise().maxCoeff();
    // Bottom corners up onto the top half (the towel plan's first step).
    std::vector<int> grasps;
    for (double x : {lo.x() + 0.02, hi.x() - 0.02}) {
      int best = 0;
      for (int i = 0; i < flat.rows(); ++i)
        if (std::hypot(flat(i, 0) - x, flat(i, 2) - hi.z()) < std::hypot(flat(best, 0) - x, flat(best, 2) - hi.z()))
          best = i;
      grasps.push_back(best);
    }
    const StepSetup step = PrepareStep(scene, flat, FoldLine{Vec2(0, 0.5 * (lo.z() + hi.z())), Vec2(1, 0)}, grasps,
                                       setup.cloth.collision.thickness);
    std::vector<CubicBezier> paths;
    for (size_t a = 0; a < grasps.size(); ++a) paths.push_back(InitialTrajectory(step.p0[a], step.p3[a]));
    const StepSim one = SimulateStep(scene, step, paths, FoldSimOptions{});
    std::printf("%-8.3f %6d %6d | %5.2f s (%.2f s sim, %5d st) | ", edge, setup.garment.mesh.NumVertices(),
                setup.garment.mesh.NumFaces(), one.wall_seconds, one.sim_time, one.steps);
    if (max_sims <= 0) {
      std::printf("-\n");
      std::fflush(stdout);
      continue;
    }
    OptimiseOptions o;
    o.lm.max_residual_evaluations = max_sims;
    const StepOptimum opt = OptimiseStep(scene, step, FoldSimOptions{}, o);
    std::printf("%3d sims %7.1f s, D %.1f -> %.1f mm (%s)\n", opt.simulations, opt.wall_seconds,
                1e3 * opt.before.dissimilarity, 1e3 * opt.after.dissimilarity, opt.lm.termination.c_str());
    std::fflush(stdout);
  }
  return 0;
}
