// Sweep benchmarks, one run: our sweep's rays/s (noise on and off) against Embree's bare
// rtcIntersect16 throughput on the same garment and the same rays, and the time of a
// 300-frame sweep of a ~2,000-vertex garment (+ PNG encoding).
// Times are process CPU seconds: the machine is shared, so rates are per CPU second (one
// core: the sweep runs with threads=1 and Embree with threads=1).
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "common/cpu_time.h"
#include "common/embree.h"
#include "generator/sweep/sweep.h"

namespace drape {
namespace {

// A folded tube hanging from the origin (a pants leg / sleeve stand-in): 40 × 51
// vertices = 2,040 vertices, 4,000 triangles, 0.95 m long.
TriMesh HangingTube() {
  const int na = 40, ny = 51;
  TriMesh m;
  m.V.resize(Eigen::Index{na} * ny, 3);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < na; ++i) {
      const double a = 2 * M_PI * i / na, y = -0.95 * j / (ny - 1);
      const double r = std::min(0.02 - y * 0.4, 0.16) * (1 + 0.12 * std::sin(5 * a + 7 * y));
      m.V.row(j * na + i) << r * std::cos(a) + 0.05 * std::sin(3 * y), y, 0.6 * r * std::sin(a);
    }
  m.F.resize(2 * Eigen::Index{na} * (ny - 1), 3);
  int k = 0;
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i < na; ++i) {
      const int a = j * na + i, b = j * na + (i + 1) % na;
      m.F.row(k++) << a, b, a + na;
      m.F.row(k++) << b, b + na, a + na;
    }
  return m;
}

const TriMesh& Garment() {
  static const TriMesh m = HangingTube();
  return m;
}

double g_rays_per_s[2] = {0, 0};  // [noise off, noise on]
double g_bare_rays_per_s = 0;
double g_sweep_seconds[2] = {0, 0};

void BM_Sweep(benchmark::State& state) {
  const bool noise = state.range(0) != 0;
  SweepOptions o;
  o.kinect.noise = noise;
  int64_t rays = 0;
  double seconds = 0;
  for (auto _ : state) {
    const double t0 = ProcessCpuSeconds();
    Sweep s = SimulateSweep(Garment(), o, 1);
    seconds += ProcessCpuSeconds() - t0;
    rays += s.stats.rays_cast;
    benchmark::DoNotOptimize(s.frames[0].depth.data());
  }
  g_rays_per_s[noise] = rays / seconds;
  g_sweep_seconds[noise] = seconds / state.iterations();
  state.counters["Mrays_per_cpu_s"] = rays / seconds / 1e6;
  state.counters["frames_per_cpu_s"] = state.iterations() * o.frames / seconds;
  state.SetLabel(noise ? "300 frames, noise on" : "300 frames, noise off");
}
BENCHMARK(BM_Sweep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// What pinning Embree's ISA costs (issue 5): the same noise-free sweep with the pinned
// AVX2 kernels against Embree's own choice (AVX-512 on this machine's kind).
void BM_SweepIsa(benchmark::State& state) {
  SweepOptions o;
  o.kinect.noise = false;
  o.embree_isa = state.range(0) ? "" : "avx2";
  double seconds = 0;
  for (auto _ : state) {
    const double t0 = ProcessCpuSeconds();
    Sweep s = SimulateSweep(Garment(), o, 1);
    seconds += ProcessCpuSeconds() - t0;
    benchmark::DoNotOptimize(s.frames[0].depth.data());
  }
  state.counters["cpu_s_per_sweep"] = seconds / state.iterations();
  state.SetLabel(state.range(0) ? "Embree's best ISA" : "isa=avx2 (pinned, release default)");
}
BENCHMARK(BM_SweepIsa)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same rays (the per-frame region of interest, object frame, 4×4 tiles, plus one
// background frame) through bare rtcIntersect16 on the same triangles: no noise, no
// images, no bookkeeping.
void BM_EmbreeBare(benchmark::State& state) {
  SweepOptions o;
  SweepScene ours(Garment(), o);
  RTCDevice device = NewEmbreeDevice(kEmbreeIsa, 1);
  RTCScene scene = rtcNewScene(device);
  RTCScene bg_scene = rtcNewScene(device);
  {
    const TriMesh& m = Garment();
    RTCGeometry g = NewTriangleGeometry(device, m);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
  }
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  rtcCommitScene(scene);
  rtcCommitScene(bg_scene);
  const Intrinsics K = o.kinect.intrinsics;
  std::vector<PixelRect> rois;
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < o.frames; ++i) {
    rois.push_back(ours.Roi(FrameAngle(o, i)));
    poses.push_back(ObjectToWorld(o, FrameAngle(o, i)).inverse() * CameraToWorld(o));
  }
  int64_t rays = 0;
  double seconds = 0;
  for (auto _ : state) {
    const double t0 = ProcessCpuSeconds();
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(64) RTCRayHit16 rh;
    alignas(64) int valid[16];
    for (int k = 0; k < 16; ++k) valid[k] = -1;
    float sink = 0;
    for (int i = 0; i < o.frames; ++i) {
      const Eigen::Matrix3f R = poses[i].linear().cast<float>();
      const Eigen::Vector3f org = poses[i].translation().cast<float>();
      const PixelRect& r = rois[i];
      for (int tv = r.v0; tv < r.v1; tv += 4)
        for (int tu = r.u0; tu < r.u1; tu += 4) {
          for (int k = 0; k < 16; ++k) {
            const Eigen::Vector3f d =
                R * Eigen::Vector3f(float((tu + (k & 3) - K.cx) / K.fx), float((tv + (k >> 2) - K.cy) / K.fy), 1.0f);
            rh.ray.org_x[k] = org.x(), rh.ray.org_y[k] = org.y(), rh.ray.org_z[k] = org.z();
            rh.ray.dir_x[k] = d.x(), rh.ray.dir_y[k] = d.y(), rh.ray.dir_z[k] = d.z();
            rh.ray.tnear[k] = 0, rh.ray.tfar[k] = INFINITY, rh.ray.time[k] = 0;
            rh.ray.mask[k] = ~0u, rh.ray.id[k] = k, rh.ray.flags[k] = 0;
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
          }
          rtcIntersect16(valid, scene, &ctx, &rh);
          sink += rh.ray.tfar[5];
          rays += 16;
        }
    }
    benchmark::DoNotOptimize(sink);
    seconds += ProcessCpuSeconds() - t0;
  }
  g_bare_rays_per_s = rays / seconds;
  state.counters["Mrays_per_cpu_s"] = rays / seconds / 1e6;
  rtcReleaseScene(scene);
  rtcReleaseScene(bg_scene);
  rtcReleaseDevice(device);
}
BENCHMARK(BM_EmbreeBare)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_EncodeSweep(benchmark::State& state) {
  SweepOptions o;
  const Sweep s = SimulateSweep(Garment(), o, 1);
  size_t bytes = 0;
  double seconds = 0;
  for (auto _ : state) {
    const double t0 = ProcessCpuSeconds();
    const auto files = EncodeSweep(s);
    seconds += ProcessCpuSeconds() - t0;
    bytes = 0;
    for (const auto& f : files) bytes += f.second.size();
  }
  state.counters["MB_per_sweep"] = double(bytes) / 1e6;
  state.counters["cpu_s_per_sweep"] = seconds / state.iterations();
  state.SetLabel("300 noisy frames → PNG + cameras.json");
}
BENCHMARK(BM_EncodeSweep)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace drape

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  using namespace drape;
  std::printf("\ngarment: %d vertices, %d triangles; 300 frames of 640x480; rates per CPU second\n",
              Garment().NumVertices(), Garment().NumFaces());
  if (g_bare_rays_per_s > 0) {
    std::printf("Embree bare rtcIntersect16:  %.1f Mrays/s\n", g_bare_rays_per_s / 1e6);
    for (int n = 0; n < 2; ++n)
      if (g_rays_per_s[n] > 0)
        std::printf("our sweep, noise %-3s:        %.1f Mrays/s = %.2f x bare; %.3f CPU s per 300-frame sweep\n",
                    n ? "on" : "off", g_rays_per_s[n] / 1e6, g_rays_per_s[n] / g_bare_rays_per_s, g_sweep_seconds[n]);
  }
  return 0;
}
