// Fusion throughput: fused frames per second against the Kinect's 30 fps capture rate,
// on 300 frames at 640×480 of a garment-sized object (torso + two sleeves): the
// Embree Kinect sweep (noise, dropouts, scene) of its mesh.
#include <benchmark/benchmark.h>

#include "generator/fusion/fusion.h"
#include "generator/fusion/synthetic.h"
#include "generator/sweep/sweep.h"

namespace {

using namespace drape;

TriMesh Concat(const std::vector<TriMesh>& parts) {
  TriMesh out;
  int nv = 0, nf = 0;
  for (const auto& m : parts) nv += m.NumVertices(), nf += m.NumFaces();
  out.V.resize(nv, 3);
  out.F.resize(nf, 3);
  int v = 0, f = 0;
  for (const auto& m : parts) {
    out.V.middleRows(v, m.NumVertices()) = m.V;
    out.F.middleRows(f, m.NumFaces()) = m.F.array() + v;
    v += m.NumVertices();
    f += m.NumFaces();
  }
  return out;
}

const std::vector<DepthFrame>& Frames() {
  static const std::vector<DepthFrame> frames = [] {
    using synthetic::Shape;
    const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix();
    const TriMesh garment =
        Concat({synthetic::MeshShape(Shape::Box(Vec3(0, -0.4, 0), Vec3(0.25, 0.35, 0.05))),
                synthetic::MeshShape(Shape::Cylinder(Vec3(0.33, -0.25, 0), 0.06, 0.2, tilt)),
                synthetic::MeshShape(Shape::Cylinder(Vec3(-0.3, -0.3, 0.02), 0.05, 0.22, tilt.transpose()))});
    SweepOptions so;
    so.frames = 300;
    return SimulateSweep(garment, so, 1).frames;
  }();
  return frames;
}

// Args: threads, frames stride, reference path (1) or fast path (0). 384 voxels/m.
void BM_FuseSweep(benchmark::State& state) {
  const auto& frames = Frames();
  FusionOptions o;
  o.threads = static_cast<int>(state.range(0));
  o.frames_stride = static_cast<int>(state.range(1));
  const bool reference = state.range(2) != 0;
  FusionStats stats;
  for (auto _ : state) {
    if (reference) {
      Tsdf tsdf(o);
      for (size_t i = 0; i < frames.size(); i += o.frames_stride) tsdf.IntegrateReference(frames[i], Intrinsics());
      stats = tsdf.Stats();
      benchmark::DoNotOptimize(tsdf.Sdf(Vec3(0, -0.4, 0)));
    } else {
      const FusionResult r = FuseFrames(frames, Intrinsics(), o, 0, /*extract_mesh=*/false);
      stats = r.stats;
      benchmark::DoNotOptimize(r.tsdf->Sdf(Vec3(0, -0.4, 0)));
    }
  }
  state.SetLabel(reference ? "reference path" : "fast path");
  if (!reference) {
    // ms per frame, wall and CPU of the whole process (all threads).
    const double f = 1e3 / std::max(1, stats.frames_integrated);
    const std::pair<const char*, double FusionStats::Steps::*> steps[] = {{"segment", &FusionStats::Steps::segment},
                                                                          {"dropouts", &FusionStats::Steps::dropouts},
                                                                          {"allocate", &FusionStats::Steps::allocate},
                                                                          {"update", &FusionStats::Steps::update},
                                                                          {"carve", &FusionStats::Steps::carve}};
    for (const auto& [name, field] : steps) {
      state.counters[std::string("ms_") + name] = stats.steps.*field * f;
      state.counters[std::string("cpu_ms_") + name] = stats.steps_cpu.*field * f;
    }
  }
  // Rates over CPU time of the calling thread (single-threaded runs are the budget).
  const double n = double(stats.frames_integrated) * state.iterations();
  state.counters["fused_fps"] = benchmark::Counter(n, benchmark::Counter::kIsRate);
  state.counters["fps_vs_30"] = benchmark::Counter(n / 30.0, benchmark::Counter::kIsRate);
  state.counters["blocks"] = stats.surface_blocks;
  state.counters["voxel_updates_per_frame"] = double(stats.voxel_updates) / frames.size();
}
BENCHMARK(BM_FuseSweep)
    ->Args({1, 3, 1})
    ->Args({1, 3, 0})
    ->Args({1, 1, 0})
    ->Args({2, 3, 0})
    ->Args({2, 1, 0})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

void BM_ExtractMeshAndVdb(benchmark::State& state) {
  const auto& frames = Frames();
  Tsdf tsdf{FusionOptions()};
  for (const auto& f : frames) tsdf.Integrate(f, Intrinsics());
  for (auto _ : state) {
    const TriMesh m = tsdf.ExtractMesh();
    const std::string vdb = tsdf.EncodeVdb();
    state.counters["faces"] = m.NumFaces();
    state.counters["vdb_bytes"] = double(vdb.size());
  }
}
BENCHMARK(BM_ExtractMeshAndVdb)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
