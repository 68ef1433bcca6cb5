// Cost of CollisionHandler::Apply per step on a real two-layer garment (tshirt M,
// 1,666 nodes), split into broad phase, strain limiting, proximity, CCD + impulses
// and impact zones. The states come from a minimal dynamics run inside the benchmark
// (Verlet with gravity, the collar held still, Apply after every step), so they look
// like a hang: layers falling onto each other, then resting in contact.
// Target: ~1–2 ms per step at 1000 nodes (a hang is ~1000–2000 steps, ≤ 5 CPU-s).
#include <benchmark/benchmark.h>

#include <algorithm>

#include "common/cpu_time.h"
#include "garments/templates.h"
#include "generator/cloth/collision.h"

namespace drape {
namespace {

struct Sim {
  Garment garment;
  Points3 x, prev;
  Eigen::VectorXd inv_mass;
  CollisionHandler handler;

  static Sim Make() {
    Garment g = MakeGarment("tshirt", TemplateOptions{});
    CollisionOptions o;
    o.max_strain = 0.06;
    Sim s{g, g.mesh.V, g.mesh.V, Eigen::VectorXd::Ones(g.mesh.NumVertices()), CollisionHandler(g.mesh.F, g.mesh.V, o)};
    // Hold the nodes within 2 cm of the collar anchor (or of the highest node).
    const Anchor* a = g.FindAnchor("collar");
    Eigen::Index top = 0;
    g.mesh.V.col(1).maxCoeff(&top);
    const Vec3 grip = a ? a->position : Vec3(g.mesh.V.row(top).transpose());
    for (int i = 0; i < g.mesh.NumVertices(); ++i)
      if ((g.mesh.V.row(i).transpose() - grip).norm() < 0.02) s.inv_mass[i] = 0;
    return s;
  }

  CollisionReport Step(double dt) {
    Points3 x1 = x + 0.99 * (x - prev);
    for (int i = 0; i < x1.rows(); ++i) {
      if (inv_mass[i] == 0)
        x1.row(i) = x.row(i);
      else
        x1(i, 1) -= 9.81 * dt * dt;
    }
    const CollisionReport rep = handler.Apply(x, x1, inv_mass, dt, {});
    prev = x;
    x = x1;
    return rep;
  }
};

// range(0): steps simulated before timing (0: "violent", the falling phase; 720:
// "damped", 3 s in, settled). Phase counters are thread CPU ms per step.
void BM_CollisionStep(benchmark::State& state) {
  state.SetLabel(state.range(0) == 0 ? "violent (falling)" : "damped (3 s in)");
  const double dt = 1.0 / 240;
  Sim sim = Sim::Make();
  for (int i = 0; i < state.range(0); ++i) sim.Step(dt);
  double broad = 0, strain = 0, prox = 0, ccd = 0, zone = 0, collider = 0;
  double steps = 0, fail_safe = 0, ccd_pairs = 0, prox_pairs = 0, zones = 0, remaining = 0, total = 0;
  double strain_max = 0, violations = 0, builds = 0, searches = 0, candidates = 0, ccd_tests = 0, passes = 0;
  for (auto _ : state) {
    const double t0 = ThreadCpuSeconds();
    const CollisionReport r = sim.Step(dt);
    total += ThreadCpuSeconds() - t0;
    strain_max = std::max(strain_max, r.max_strain);
    violations += r.strain_violations;
    broad += r.broad_seconds;
    strain += r.strain_seconds;
    prox += r.proximity_seconds;
    ccd += r.ccd_seconds;
    zone += r.zone_seconds;
    collider += r.collider_seconds;
    steps += 1;
    fail_safe += r.fail_safe_used;
    ccd_pairs += r.ccd_collisions;
    prox_pairs += r.proximity_pairs;
    zones += r.impact_zones;
    remaining += r.remaining_collisions;
    builds += r.broad_builds;
    searches += r.broad_searches;
    candidates += double(r.broad_candidates);
    ccd_tests += double(r.ccd_tests);
    passes += r.ccd_passes + r.zone_iterations;
  }
  state.counters["nodes"] = static_cast<double>(sim.x.rows());
  state.counters["apply_cpu_ms"] = 1e3 * total / steps;
  state.counters["strain_max"] = strain_max;
  state.counters["strain_violations"] = violations;
  state.counters["broad_ms"] = 1e3 * broad / steps;
  state.counters["strain_ms"] = 1e3 * strain / steps;
  state.counters["prox_ms"] = 1e3 * prox / steps;
  state.counters["ccd_ms"] = 1e3 * ccd / steps;
  state.counters["zone_ms"] = 1e3 * zone / steps;
  state.counters["collider_ms"] = 1e3 * collider / steps;
  state.counters["fail_safe_frac"] = fail_safe / steps;
  state.counters["ccd_pairs"] = ccd_pairs / steps;
  state.counters["prox_pairs"] = prox_pairs / steps;
  state.counters["zones"] = zones / steps;
  state.counters["remaining"] = remaining;
  state.counters["broad_builds"] = builds / steps;
  state.counters["broad_searches"] = searches / steps;
  state.counters["cand_per_build"] = builds > 0 ? candidates / builds : 0;
  state.counters["ccd_tests"] = ccd_tests / steps;
  state.counters["passes"] = passes / steps;
  state.counters["min_dist_mm"] = 1e3 * MinimumNonAdjacentDistance(sim.garment.mesh.F, sim.x);
}
BENCHMARK(BM_CollisionStep)->Arg(0)->Arg(720)->Iterations(240)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace drape

BENCHMARK_MAIN();
