// Matching throughput (database entries × rotations per second) against the machine's
// XOR-popcount limit measured in the same run, and the latency of one whole query.
//
//   recognition_bench [--benchmark_filter=...]
//
// The "limit" is a bare loop popcounting an L1-resident array with the same
// instruction the matcher uses (POPCNT on 64-bit words, or AVX-512 VPOPCNTDQ on 8
// words); the matcher's counter "of_limit" is its words/s divided by that.
#include <benchmark/benchmark.h>

#include <bit>
#include <cstdio>
#include <map>

#include "common/cpu_time.h"
#include "common/rng.h"
#include "common/timing.h"
#include "generator/feature/feature.h"
#include "generator/fusion/fusion.h"
#include "generator/fusion/synthetic.h"
#include "generator/sweep/sweep.h"
#include "runtime/recognition/recognizer.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace drape::recognition {
namespace {

Code RandomCode(Rng& rng, int l, int r, int s) {
  Code c = ZeroFeature(l, r, s);
  for (auto& w : c.words) w = rng.NextU64();
  if (c.NumBits() % 64) c.words.back() &= (uint64_t{1} << (c.NumBits() % 64)) - 1;
  return c;
}

constexpr int kWords = 1024;  // 8 KiB per array: L1-resident like the query's rotations

// The bare loops popcount one L1-resident array (one load + one popcount per word or
// per 8 words, four independent accumulators): the machine's popcount throughput. The
// matcher does an XOR more per step but keeps the database row in registers, so it also
// needs one load per step.
uint64_t BarePopcnt(const uint64_t* a, const uint64_t*, int n) __attribute__((target("popcnt")));
uint64_t BarePopcnt(const uint64_t* a, const uint64_t*, int n) {
  uint64_t s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  for (int i = 0; i < n; i += 4) {
    s0 += __builtin_popcountll(a[i]);
    s1 += __builtin_popcountll(a[i + 1]);
    s2 += __builtin_popcountll(a[i + 2]);
    s3 += __builtin_popcountll(a[i + 3]);
  }
  return s0 + s1 + s2 + s3;
}

#if defined(__x86_64__)
// gcc 12's own avx512fintrin.h: _mm512_reduce_add_epi64 extracts a half through
// _mm256_undefined_si256(), which -Wuninitialized reports once inlined here (gcc bug
// 105593, as in matcher.cpp's MatchAvx512). Only that warning, only around this function.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
__attribute__((target("avx512f,avx512vpopcntdq"))) uint64_t BareAvx512(const uint64_t* a, const uint64_t*, int n) {
  __m512i acc0 = _mm512_setzero_si512(), acc1 = _mm512_setzero_si512();
  __m512i acc2 = _mm512_setzero_si512(), acc3 = _mm512_setzero_si512();
  for (int i = 0; i < n; i += 32) {
    acc0 = _mm512_add_epi64(acc0, _mm512_popcnt_epi64(_mm512_loadu_si512(a + i)));
    acc1 = _mm512_add_epi64(acc1, _mm512_popcnt_epi64(_mm512_loadu_si512(a + i + 8)));
    acc2 = _mm512_add_epi64(acc2, _mm512_popcnt_epi64(_mm512_loadu_si512(a + i + 16)));
    acc3 = _mm512_add_epi64(acc3, _mm512_popcnt_epi64(_mm512_loadu_si512(a + i + 24)));
  }
  return _mm512_reduce_add_epi64(_mm512_add_epi64(_mm512_add_epi64(acc0, acc1), _mm512_add_epi64(acc2, acc3)));
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
#endif

// Words per second of the bare loop for a kernel, measured once (≈0.2 s of this thread's
// CPU time: Google Benchmark's rates are per CPU second too, so a busy machine does not
// skew the ratio).
double Limit(Kernel k) {
  static std::map<Kernel, double> cache;
  if (cache.count(k)) return cache[k];
  Rng rng(1);
  std::vector<uint64_t> a(kWords), b(kWords);
  for (auto& v : a) v = rng.NextU64();
  for (auto& v : b) v = rng.NextU64();
  uint64_t sink = 0;
  long long words = 0;
  const double t0 = ThreadCpuSeconds();
  double secs = 0;
  while (secs < 0.2) {
    for (int rep = 0; rep < 1000; ++rep) {
#if defined(__x86_64__)
      sink += k == Kernel::kAvx512 ? BareAvx512(a.data(), b.data(), kWords) : BarePopcnt(a.data(), b.data(), kWords);
#else
      sink += BarePopcnt(a.data(), b.data(), kWords);
#endif
      a[rep & (kWords - 1)] ^= sink;  // keep the loop honest
    }
    words += 1000LL * kWords;
    secs = ThreadCpuSeconds() - t0;
  }
  benchmark::DoNotOptimize(sink);
  return cache[k] = words / secs;
}

void BM_BarePopcountLimit(benchmark::State& state) {
  const Kernel k = static_cast<Kernel>(state.range(0));
  if (!KernelAvailable(k)) {
    state.SkipWithError("kernel not available on this CPU");
    return;
  }
  Rng rng(2);
  std::vector<uint64_t> a(kWords), b(kWords);
  for (auto& v : a) v = rng.NextU64();
  for (auto& v : b) v = rng.NextU64();
  for (auto _ : state) {
#if defined(__x86_64__)
    benchmark::DoNotOptimize(k == Kernel::kAvx512 ? BareAvx512(a.data(), b.data(), kWords)
                                                  : BarePopcnt(a.data(), b.data(), kWords));
#endif
    benchmark::ClobberMemory();
  }
  state.SetLabel(KernelName(k));
  state.counters["words/s"] = benchmark::Counter(double(state.iterations()) * kWords, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BarePopcountLimit)->Arg(int(Kernel::kPopcnt))->Arg(int(Kernel::kAvx512));

// Eq. match of one query against N database entries (16×16×16 features, Φ = 16).
void BM_MatchAll(benchmark::State& state) {
  const Kernel k = static_cast<Kernel>(state.range(0));
  const int n = static_cast<int>(state.range(1));
  if (!KernelAvailable(k)) {
    state.SkipWithError("kernel not available on this CPU");
    return;
  }
  Rng rng(3);
  Matcher m(16, 16, 16, k);
  for (int i = 0; i < n; ++i) m.Add(RandomCode(rng, 16, 16, 16), "bench");
  const PreparedQuery q(RandomCode(rng, 16, 16, 16));
  std::vector<Match> out;
  for (auto _ : state) {
    m.MatchAll(q, &out);
    benchmark::DoNotOptimize(out.data());
  }
  const double pairs = double(state.iterations()) * n * 16;  // entries × rotations
  const double words = pairs * q.padded_words();
  state.SetLabel(KernelName(k));
  state.counters["entry_rotations/s"] = benchmark::Counter(pairs, benchmark::Counter::kIsRate);
  state.counters["words/s"] = benchmark::Counter(words, benchmark::Counter::kIsRate);
  if (k != Kernel::kGeneric) {
    state.counters["of_limit"] = benchmark::Counter(words / Limit(k), benchmark::Counter::kIsRate);
  }
}
BENCHMARK(BM_MatchAll)
    ->ArgsProduct({{int(Kernel::kGeneric), int(Kernel::kPopcnt), int(Kernel::kAvx512)}, {70, 1000, 10000}});

// One whole query as `drape recognize` runs it after loading: prepare the Φ rotations,
// Eq. match over the database, category by NN, weighted pose ranking in the category.
// 70 entries ≈ the paper's database (shirts 2×19, pants 2×12, shorts 8, one material).
// n random 16×16×16 codes labelled over three categories, two instances, 12 anchors.
std::vector<LabelledCode> RandomDatabase(Rng& rng, int n) {
  // Appended, not "e" + std::to_string(i): gcc 12 -O3 reports a bogus -Wrestrict inside
  // libstdc++ when a string is built from a one-character literal (gcc bug 105329).
  const auto named = [](std::string name, int i) { return name += std::to_string(i); };
  std::vector<LabelledCode> v;
  for (int i = 0; i < n; ++i) {
    LabelledCode lc;
    lc.label.id = named("e", i);
    lc.label.category = i % 3 == 0 ? "shirt" : i % 3 == 1 ? "pants" : "shorts";
    lc.label.instance = lc.label.category + std::to_string(i % 2);
    lc.label.anchor = named("a", i % 12);
    lc.code = RandomCode(rng, 16, 16, 16);
    v.push_back(std::move(lc));
  }
  return v;
}

void BM_WholeQuery(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const bool weighted = state.range(1) != 0;
  Rng rng(4);
  Database db(RandomDatabase(rng, n));
  Weights w;
  w.layers = w.rings = w.sectors = 16;
  for (const char* c : {"shirt", "pants", "shorts"}) {
    std::vector<double> ww(4096);
    for (double& x : ww) x = rng.Uniform();
    w.per_category[c] = ww;
  }
  Recognizer rec(db, weighted ? &w : nullptr);
  const Code q = RandomCode(rng, 16, 16, 16);
  RecognizeOptions o;
  for (auto _ : state) {
    const Recognition r = rec.Recognize(q, o);
    benchmark::DoNotOptimize(r.best.entry);
  }
  state.SetLabel(std::string(KernelName(db.matcher().kernel())) + (weighted ? ", learned w" : ", unweighted"));
}
BENCHMARK(BM_WholeQuery)->ArgsProduct({{70, 1000}, {0, 1}})->Unit(benchmark::kMicrosecond);

// The paper's query: a 300-frame Kinect sweep (noise, dropouts, gripper, table, wall,
// floor) of a garment-sized object (torso + two sleeves), fused, the feature, and
// matching against 70 entries; timed stage by stage. Args: frame stride, voxels per
// metre, feature path (0: Algorithm 1 on the vertices of the extracted mesh, as the
// release builds; 1: on the field's zero crossings, Tsdf::SurfacePoints, no mesh).
// Counters: ms per query by stage, CPU of the whole process (both cores; on a machine
// shared with other jobs the CPU figure is the one to compare with the paper's
// 0.20–0.30 s) and wall (the paper's figure is wall time); frames fused per CPU second
// and per wall second (fusion as the query pipeline runs it: FuseFrames on every core);
// bits_vs_reference: feature bits
// (of 4096) that differ from the all-frames, mesh-path feature at the same voxel size
// (the slow reference).
const std::vector<DepthFrame>& PaperSweep(Intrinsics* K) {
  static Intrinsics k;
  static const std::vector<DepthFrame> frames = [] {
    using synthetic::Shape;
    const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix();
    TriMesh garment;
    for (const TriMesh& m :
         {synthetic::MeshShape(Shape::Box(Vec3(0, -0.4, 0), Vec3(0.25, 0.35, 0.05))),
          synthetic::MeshShape(Shape::Cylinder(Vec3(0.33, -0.25, 0), 0.06, 0.2, tilt)),
          synthetic::MeshShape(Shape::Cylinder(Vec3(-0.3, -0.3, 0.02), 0.05, 0.22, tilt.transpose()))})
      synthetic::AppendMesh(garment, m);
    SweepOptions so;
    so.frames = 300;
    so.threads = 0;
    Sweep s = SimulateSweep(garment, so, 1);
    k = s.intrinsics;
    return s.frames;
  }();
  *K = k;
  return frames;
}

// stage → (wall s, CPU s), summed over iterations.
using StageTimes = std::map<std::string, std::pair<double, double>>;

Feature QueryFeature(const std::vector<DepthFrame>& frames, const Intrinsics& K, int stride, double voxels_per_metre,
                     bool field, StageTimes* steps) {
  auto lap = [&, w0 = Clock::now(), c0 = ProcessCpuSeconds()](const char* name) mutable {
    const auto w1 = Clock::now();
    const double c1 = ProcessCpuSeconds();
    if (steps) {
      (*steps)[name].first += Seconds(w0, w1);
      (*steps)[name].second += c1 - c0;
    }
    w0 = w1, c0 = c1;
  };
  FusionOptions o;
  o.voxels_per_metre = voxels_per_metre;
  o.frames_stride = stride;
  o.threads = 0;  // as the query pipeline: every core
  // As the query pipeline fuses (FuseFrames completes the field for its stats).
  const FusionResult fused = FuseFrames(frames, K, o, 0, /*extract_mesh=*/false);
  const Tsdf& tsdf = *fused.tsdf;
  const FusionStats& st = fused.stats;
  lap("fusion");
  if (steps) {
    // Integrate's own steps (segmentation = box test + dropouts); completion = the rest
    // of FuseFrames (rules 2 and 3 of fusion.h).
    const std::pair<const char*, std::pair<double, double>> sub[] = {
        {"f_segmentation", {st.steps.segment + st.steps.dropouts, st.steps_cpu.segment + st.steps_cpu.dropouts}},
        {"f_allocation", {st.steps.allocate, st.steps_cpu.allocate}},
        {"f_update", {st.steps.update, st.steps_cpu.update}},
        {"f_carving", {st.steps.carve, st.steps_cpu.carve}}};
    std::pair<double, double> integrate{0, 0};
    for (const auto& [name, t] : sub) {
      (*steps)[name].first += t.first, (*steps)[name].second += t.second;
      integrate.first += t.first, integrate.second += t.second;
    }
    // "fusion" (FuseFrames) = integration + completion.
    (*steps)["fusion"].first -= fused.stats.wall_seconds - integrate.first;
    (*steps)["completion"].first += fused.stats.wall_seconds - integrate.first;
    const double cpu_complete = (*steps)["fusion"].second - integrate.second;
    (*steps)["fusion"].second -= cpu_complete;
    (*steps)["completion"].second += cpu_complete;
  }
  Points3 points;
  if (field) {
    points = tsdf.SurfacePoints();
    lap("surface_points");
  } else {
    points = tsdf.ExtractMesh().V;
    lap("mesh");
  }
  Feature f = ExtractFeature(
      points, [&tsdf](const Vec3& p) { return tsdf.Sdf(p); }, FeatureOptions());
  lap("feature");
  return f;
}

void BM_PaperQuery(benchmark::State& state) {
  const int stride = static_cast<int>(state.range(0)), vpm = static_cast<int>(state.range(1));
  const bool field = state.range(2) != 0;
  Intrinsics K;
  const auto& frames = PaperSweep(&K);
  static std::map<int, Feature> references;
  if (!references.count(vpm)) references[vpm] = QueryFeature(frames, K, 1, vpm, false, nullptr);
  const Feature& reference = references[vpm];
  Rng rng(5);
  Database db(RandomDatabase(rng, 70));
  Recognizer rec(db, nullptr);
  StageTimes steps;
  Feature f;
  for (auto _ : state) {
    f = QueryFeature(frames, K, stride, vpm, field, &steps);
    const auto w0 = Clock::now();
    const double c0 = ProcessCpuSeconds();
    Code q = ZeroFeature(f.layers, f.rings, f.sectors);
    q.words = f.words;
    benchmark::DoNotOptimize(rec.Recognize(q, RecognizeOptions()).best.entry);
    steps["matching"].first += Since(w0);
    steps["matching"].second += ProcessCpuSeconds() - c0;
  }
  double wall = 0, cpu = 0;
  const double n = double(state.iterations());
  for (const auto& [name, t] : steps) {
    state.counters["cpu_ms_" + name] = 1e3 * t.second / n;
    if (name.rfind("f_", 0) == 0) continue;  // parts of "fusion"
    state.counters["wall_ms_" + name] = 1e3 * t.first / n;
    wall += t.first, cpu += t.second;
  }
  state.counters["wall_ms_query"] = 1e3 * wall / n;
  state.counters["cpu_ms_query"] = 1e3 * cpu / n;
  state.counters["paper_ms"] = 300;
  const size_t fused_frames = (frames.size() + stride - 1) / stride;  // every stride-th frame
  const double fused = double(fused_frames);
  state.counters["frames_per_cpu_s"] = fused * n / steps["fusion"].second;
  state.counters["frames_per_s"] = fused * n / steps["fusion"].first;
  int diff = 0;
  for (size_t w = 0; w < f.words.size(); ++w) diff += std::popcount(f.words[w] ^ reference.words[w]);
  state.counters["bits_vs_reference"] = diff;
  state.counters["frames_fused"] = fused;
  state.SetLabel("300 frames, every " + std::to_string(stride) + (stride == 1 ? "st" : "th") + ", " +
                 std::to_string(vpm) + " voxels/m, feature on " + (field ? "field zero crossings" : "mesh vertices"));
}
// The paper's settings (384 voxels/m) by both feature paths and strides, then the
// recipes' coarser fusions (paper.yaml 256, quickstart 128 voxels/m).
BENCHMARK(BM_PaperQuery)
    ->Args({1, 384, 0})
    ->Args({1, 384, 1})
    ->Args({3, 384, 0})
    ->Args({3, 384, 1})
    ->Args({6, 384, 1})
    ->Args({3, 256, 1})
    ->Args({3, 128, 1})
    ->Args({6, 128, 1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace
}  // namespace drape::recognition

int main(int argc, char** argv) {
  using namespace drape::recognition;
  std::printf("XOR-popcount limit (bare loop, L1): POPCNT %.3g words/s",
              KernelAvailable(Kernel::kPopcnt) ? Limit(Kernel::kPopcnt) : 0.0);
  if (KernelAvailable(Kernel::kAvx512)) std::printf(", AVX-512 VPOPCNTDQ %.3g words/s", Limit(Kernel::kAvx512));
  std::printf(" (4096-bit feature = 64 words; one entry × rotation = 64 words)\n");
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
