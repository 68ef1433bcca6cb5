// Simulation cost of one hang job vs node count: wall time per job, Bullet steps per
// second, and the share of the job spent outside Bullet's stepSimulation (our overhead:
// proximity pass, settle checks, equilibrium solve).
#include <benchmark/benchmark.h>

#include <cmath>

#include "generator/hang/hang.h"

namespace drape {
namespace {

const MaterialFit& Fit() {
  static const MaterialFit fit = FitMaterial(*FindMaterialPreset("tshirt"), HangOptions{});
  return fit;
}

// Two-layer rectangle with about `nodes` nodes (aspect 2:3), hung from a top corner.
void BM_HangJob(benchmark::State& state) {
  const double nodes = static_cast<double>(state.range(0));
  const double area = 0.4 * 0.6, edge = std::sqrt(2 * area / nodes);
  const Garment g = MakeRectangleGarment(0.4, 0.6, edge, true);
  HangOptions o;
  o.equilibrium_solve = state.range(1) != 0;
  double rel = 0, applied = 0;
  double steps = 0, wall = 0, bullet = 0, settled = 0, contact = 0, eq = 0, sim = 0;
  for (auto _ : state) {
    const HangResult r = Hang(g, g.anchors[0].vertex, Vec3::Zero(), *FindMaterialPreset("tshirt"), Fit(), o, 1);
    steps += r.stats.steps * (r.stats.retries + 1);
    wall += r.stats.wall_seconds;
    bullet += r.stats.bullet_seconds;
    contact += r.stats.contact_seconds;
    eq += r.stats.equilibrium_seconds;
    sim += r.stats.sim_time;
    rel = r.stats.force_residual_rel;
    applied += r.stats.equilibrium_applied;
    settled += r.ok;
  }
  state.counters["nodes"] = g.mesh.NumVertices();
  state.counters["steps_per_s"] = steps / std::max(wall, 1e-9);
  state.counters["overhead_share"] = 1 - bullet / std::max(wall, 1e-9);
  state.counters["ok_share"] = settled / state.iterations();
  state.counters["contact_share"] = contact / std::max(wall, 1e-9);
  state.counters["equilibrium_share"] = eq / std::max(wall, 1e-9);
  state.counters["sim_time"] = sim / state.iterations();
  state.counters["fit_s"] = Fit().wall_seconds;
  state.counters["residual_rel"] = rel;  // max |F|/(m g) of the returned state
  state.counters["eq_applied"] = applied / state.iterations();
}
// Args: {nodes, equilibrium solve on/off}.
BENCHMARK(BM_HangJob)
    ->Args({500, 1})->Args({1000, 1})->Args({2000, 1})
    ->Args({500, 0})->Args({1000, 0})->Args({2000, 0})
    ->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace drape

BENCHMARK_MAIN();
