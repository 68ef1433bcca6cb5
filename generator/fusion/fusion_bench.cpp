// Fusion throughput: fused frames per second against the Kinect's 30 fps capture rate,
// on 300 frames at 640×480 of a garment-sized analytic object (torso + two sleeves).
#include <benchmark/benchmark.h>

#include "generator/fusion/fusion.h"
#include "generator/fusion/synthetic.h"

namespace {

using namespace drape;

const std::vector<DepthFrame>& Frames() {
  static const std::vector<DepthFrame> frames = [] {
    synthetic::Scene garment;
    garment.shapes.push_back(synthetic::Shape::Box(Vec3(0, -0.4, 0), Vec3(0.25, 0.35, 0.05)));
    const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix();
    garment.shapes.push_back(synthetic::Shape::Cylinder(Vec3(0.33, -0.25, 0), 0.06, 0.2, tilt));
    garment.shapes.push_back(synthetic::Shape::Cylinder(Vec3(-0.3, -0.3, 0.02), 0.05, 0.22, tilt.transpose()));
    synthetic::TurntableOptions t;
    t.frames = 300;
    t.noise_sigma = 0.002;
    return synthetic::RenderTurntable(garment, Intrinsics(), t);
  }();
  return frames;
}

void BM_FuseSweep(benchmark::State& state) {
  const auto& frames = Frames();
  FusionOptions o;
  o.threads = static_cast<int>(state.range(0));
  FusionStats stats;
  for (auto _ : state) {
    Tsdf tsdf(o);
    for (const auto& f : frames) tsdf.Integrate(f, Intrinsics());
    stats = tsdf.Stats();
    benchmark::DoNotOptimize(tsdf.Sdf(Vec3(0, -0.4, 0)));
  }
  state.counters["fused_fps"] = benchmark::Counter(double(frames.size()) * state.iterations(),
                                                   benchmark::Counter::kIsRate);
  state.counters["fps_vs_30"] = benchmark::Counter(double(frames.size()) * state.iterations() / 30.0,
                                                   benchmark::Counter::kIsRate);
  state.counters["blocks"] = stats.surface_blocks;
  state.counters["voxel_updates_per_frame"] = double(stats.voxel_updates) / frames.size();
}
BENCHMARK(BM_FuseSweep)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);

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
