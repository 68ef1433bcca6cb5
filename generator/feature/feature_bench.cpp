// Feature extraction time on a fused garment SDF and match time per database entry
// (all Φ rotations), fast against brute force.
#include <benchmark/benchmark.h>

#include "common/rng.h"
#include "generator/feature/feature.h"
#include "generator/fusion/fusion.h"
#include "generator/fusion/synthetic.h"

namespace {

using namespace drape;

const FusionResult& Fused() {
  static const FusionResult r = [] {
    synthetic::Scene garment;
    garment.shapes.push_back(synthetic::Shape::Box(Vec3(0, -0.4, 0), Vec3(0.25, 0.35, 0.05)));
    garment.shapes.push_back(synthetic::Shape::Cylinder(Vec3(0.33, -0.25, 0), 0.06, 0.2,
                                                        Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix()));
    synthetic::TurntableOptions t;
    t.frames = 60;
    return FuseFrames(synthetic::RenderTurntable(garment, Intrinsics(), t), Intrinsics(), FusionOptions(), 1);
  }();
  return r;
}

void BM_ExtractFeature(benchmark::State& state) {
  const FusionResult& r = Fused();
  FeatureOptions o;
  for (auto _ : state) {
    const Feature f = ExtractFeature(
        r.mesh.V, [&](const Vec3& p) { return r.tsdf->Sdf(p); }, o);
    benchmark::DoNotOptimize(f.words.data());
  }
  state.counters["mesh_vertices"] = r.mesh.NumVertices();
}
BENCHMARK(BM_ExtractFeature)->Unit(benchmark::kMillisecond);

std::vector<Feature> Database(int phi, int n) {
  Rng rng(1);
  std::vector<Feature> db(n);
  for (auto& f : db) {
    f.layers = 16;
    f.rings = 16;
    f.sectors = phi;
    f.words.resize((f.NumBits() + 63) / 64);
    for (auto& w : f.words) w = rng.NextU64();
    const int used = f.NumBits() % 64;
    if (used) f.words.back() &= (uint64_t(1) << used) - 1;
  }
  return db;
}

void BM_MatchPerEntry(benchmark::State& state) {
  const int phi = static_cast<int>(state.range(0));
  const auto db = Database(phi, 1000);
  const Feature& q = db[0];
  for (auto _ : state) {
    int best = 1 << 30;
    for (const auto& f : db) best = std::min(best, Distance(q, f).distance);
    benchmark::DoNotOptimize(best);
  }
  state.SetItemsProcessed(state.iterations() * int64_t(db.size()));  // entries per second
}
BENCHMARK(BM_MatchPerEntry)->Arg(16)->Arg(12)->Arg(20);

void BM_MatchPerEntryReference(benchmark::State& state) {
  const auto db = Database(16, 20);
  for (auto _ : state) {
    int best = 1 << 30;
    for (const auto& f : db) best = std::min(best, DistanceReference(db[0], f).distance);
    benchmark::DoNotOptimize(best);
  }
  state.SetItemsProcessed(state.iterations() * int64_t(db.size()));
}
BENCHMARK(BM_MatchPerEntryReference);

}  // namespace

BENCHMARK_MAIN();
