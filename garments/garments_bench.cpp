// Time to build each template at the default edge length (CDT + refinement +
// smoothing + mirroring), and to encode it as binary PLY.
#include <benchmark/benchmark.h>

#include "garments/io.h"
#include "garments/templates.h"

namespace {

void BM_MakeGarment(benchmark::State& state, const char* name) {
  drape::TemplateOptions opt;
  for (auto _ : state) benchmark::DoNotOptimize(drape::MakeGarment(name, opt));
}
BENCHMARK_CAPTURE(BM_MakeGarment, long_sleeve_shirt, "long_sleeve_shirt")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MakeGarment, pants, "pants")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MakeGarment, towel, "towel")->Unit(benchmark::kMillisecond);

void BM_EncodePly(benchmark::State& state) {
  const drape::Garment g = drape::MakeGarment("long_sleeve_shirt", {});
  for (auto _ : state) benchmark::DoNotOptimize(drape::EncodeMesh(g.mesh));
}
BENCHMARK(BM_EncodePly)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
