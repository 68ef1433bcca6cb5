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
  double steps = 0, wall = 0, bullet = 0, settled = 0, contact = 0, eq = 0, sim = 0;
  for (auto _ : state) {
    const HangResult r = Hang(g, g.anchors[0].vertex, Vec3::Zero(), *FindMaterialPreset("tshirt"), Fit(), o, 1);
    steps += r.stats.steps * (r.stats.retries + 1);
    wall += r.stats.wall_seconds;
    bullet += r.stats.bullet_seconds;
    contact += r.stats.contact_seconds;
    eq += r.stats.equilibrium_seconds;
    sim += r.stats.sim_time;
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
}
BENCHMARK(BM_HangJob)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace drape

BENCHMARK_MAIN();
