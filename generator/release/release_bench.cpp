// Release writer costs: committing an entry (files + entry.json + syncfs + rename),
// finalizing (catalog, card, gallery, SHA256SUMS) and verifying (hashing).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include "common/rng.h"
#include "generator/release/release.h"

namespace fs = std::filesystem;

namespace drape {
namespace {

std::string Bytes(size_t n, uint64_t seed) {
  Rng rng(seed);
  std::string s(n, '\0');
  for (auto& c : s) c = static_cast<char>(rng.NextU64() & 0xff);
  return s;
}

ReleaseMeta Meta(int jobs) {
  ReleaseMeta m;
  m.name = "bench";
  m.version = "1.0.0";
  m.recipe_text = "bench";
  m.code_version = "bench";
  for (int i = 0; i < jobs; ++i) m.job_keys.push_back("job" + std::to_string(i));
  return m;
}

// A paper-sized entry: meshes ~200 KB, sdf ~1 MB, preview ~100 KB, and `frames` depth
// PNGs of ~150 KB when the sweep is kept.
Entry MakeEntry(int i, int frames) {
  Entry e;
  e.id = "e" + std::to_string(i);
  e.key = "job" + std::to_string(i);
  e.split = "train";
  e.record = {{"category", "shirt"}, {"anchor", {{"label", "a"}}}, {"fusion", {{"recon_to_truth_mean", 0.002}}}};
  e.files = {{"hang.ply", Bytes(200000, i)},
             {"recon.ply", Bytes(200000, i + 1)},
             {"sdf.vdb", Bytes(1000000, i + 2)},
             {"feature.bin", Bytes(512, i + 3)},
             {"preview.png", Bytes(100000, i + 4)}};
  for (int f = 0; f < frames; ++f) {
    char name[32];
    std::snprintf(name, sizeof(name), "sweep/%06d.png", f);
    e.files.push_back({name, Bytes(150000, i * 1000 + f)});
  }
  return e;
}

void BM_Commit(benchmark::State& state) {
  const int frames = static_cast<int>(state.range(0));
  const fs::path dir = fs::temp_directory_path() / ("drape_release_bench_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto w = ReleaseWriter::Open(dir, Meta(100000));
  const Entry proto = MakeEntry(0, frames);
  size_t bytes = 0;
  for (const auto& f : proto.files) bytes += f.bytes.size();
  int i = 0;
  for (auto _ : state) {
    Entry e = proto;
    // Built, not "e" + std::to_string(i) or assigned "e": gcc 12 -O3 reports a bogus
    // -Wrestrict inside libstdc++ when a one-character literal replaces a string's
    // contents (gcc bug 105329).
    std::string id = "e";
    id += std::to_string(i);
    e.id = std::move(id);
    e.key = "job" + std::to_string(i);
    ++i;
    w->Commit(e);
  }
  state.SetBytesProcessed(static_cast<int64_t>(bytes) * state.iterations());
  w.reset();
  fs::remove_all(dir);
}
BENCHMARK(BM_Commit)->Arg(0)->Arg(300)->Unit(benchmark::kMillisecond)->Iterations(4);

void BM_FinalizeAndVerify(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  for (auto _ : state) {
    state.PauseTiming();
    const fs::path dir = fs::temp_directory_path() / ("drape_release_bench_f_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    auto w = ReleaseWriter::Open(dir, Meta(n));
    for (int i = 0; i < n; ++i) w->Commit(MakeEntry(i, 0));
    state.ResumeTiming();
    w->Finalize();
    const VerifyReport r = Verify(dir);
    benchmark::DoNotOptimize(r.files_checked);
    state.PauseTiming();
    fs::remove_all(dir);
    state.ResumeTiming();
  }
}
BENCHMARK(BM_FinalizeAndVerify)->Arg(50)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace
}  // namespace drape

BENCHMARK_MAIN();
