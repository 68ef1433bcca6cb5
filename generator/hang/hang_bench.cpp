// Simulation cost of one hang job vs node count, in CPU seconds of the calling thread,
// split into Bullet's step, the collision handler (broad phase, CCD + impulses, rigid
// impact zones, the rest: strain limit, repulsion, colliders) and the final mesh
// measurement. There is no equilibrium solve any more; before this cloth core a
// 1,000-node job took ~4 CPU-s (Bullet + proximity pass + KINSOL), printed as
// before_cpu_s for comparison. Goals: ≤ 5 CPU-s at 1,000 nodes; a 4,000-node hang
// settled within its time cap (settled_share 1) in ≤ 15 CPU-s (issue #44).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>

#include "common/cpu_time.h"
#include "generator/hang/hang.h"

namespace drape {
namespace {

// FNV-1a over the bytes of the positions, cut to 48 bits (a counter is a double): equal
// before and after a change that claims to keep results bit-identical.
double MeshBitsHash(const Points3& x) {
  uint64_t h = 1469598103934665603ull;
  const auto* p = reinterpret_cast<const unsigned char*>(x.data());
  for (size_t k = 0; k < sizeof(double) * static_cast<size_t>(x.size()); ++k) h = (h ^ p[k]) * 1099511628211ull;
  return static_cast<double>(h >> 16);
}

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
  o.self_collision = state.range(1) != 0;
  double cpu = 0, bullet = 0, bend = 0, coll = 0, broad = 0, ccd = 0, zone = 0, strain = 0, repel = 0, measure = 0,
         sim = 0, ok = 0, settled = 0;
  double pairs = 0, strain_max = 0, fail_safe = 0, result_hash = 0;
  Fit();
  for (auto _ : state) {
    const double c0 = ThreadCpuSeconds();
    const HangResult r = Hang(g, g.anchors[0].vertex, Vec3::Zero(), *FindMaterialPreset("tshirt"), Fit(), o, 1);
    cpu += ThreadCpuSeconds() - c0;
    bullet += r.stats.bullet_seconds;
    bend += r.stats.bend_seconds;
    coll += r.stats.collision_seconds;
    broad += r.stats.broad_seconds;
    ccd += r.stats.ccd_seconds;
    zone += r.stats.zone_seconds;
    strain += r.stats.strain_seconds;
    repel += r.stats.repulsion_seconds;
    measure += r.stats.measure_seconds;
    sim += r.stats.sim_time;
    ok += r.ok;
    settled += r.stats.settled;
    pairs += r.stats.intersecting_pairs;
    strain_max = std::max(strain_max, r.stats.strain_max);
    fail_safe += r.stats.fail_safe_steps;
    result_hash = MeshBitsHash(r.mesh.V);
  }
  const double it = static_cast<double>(state.iterations());
  state.counters["nodes"] = g.mesh.NumVertices();
  state.counters["cpu_s"] = cpu / it;
  state.counters["bullet_s"] = bullet / it;
  state.counters["bend_s"] = bend / it;
  state.counters["collision_s"] = coll / it;
  state.counters["broad_s"] = broad / it;
  state.counters["ccd_s"] = ccd / it;
  state.counters["zones_s"] = zone / it;
  state.counters["strain_s"] = strain / it;
  state.counters["repulsion_s"] = repel / it;
  state.counters["measure_s"] = measure / it;
  state.counters["before_cpu_s"] = state.range(0) == 1000 ? 4.0 : 0;
  state.counters["sim_time"] = sim / it;
  state.counters["ok_share"] = ok / it;
  state.counters["settled_share"] = settled / it;
  state.counters["cgal_pairs"] = pairs / it;
  state.counters["strain_max"] = strain_max;
  state.counters["fail_safe_steps"] = fail_safe / it;
  state.counters["fit_s"] = Fit().wall_seconds;
  state.counters["result_hash"] = result_hash;  // changes when the hung mesh changes by a bit
}
// Args: {nodes, collision handler on/off}.
BENCHMARK(BM_HangJob)
    ->Args({500, 1})
    ->Args({1000, 1})
    ->Args({2000, 1})
    ->Args({4000, 1})
    ->Args({1000, 0})
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

}  // namespace
}  // namespace drape

BENCHMARK_MAIN();
