#include "runtime/recognition/query_pipeline.h"

#include "common/error.h"
#include "common/rng.h"
#include "common/timing.h"
#include "garments/io.h"
#include "generator/feature/feature.h"
#include "generator/fusion/fusion.h"
#include "generator/recipe/recipe.h"
#include "generator/sweep/sweep.h"

namespace drape::recognition {

namespace fs = std::filesystem;

namespace {

// The options the release was built with: its recipe, stored verbatim in dataset.json.
struct BuildOptions {
  FusionOptions fusion;
  FeatureOptions feature;
  SweepOptions sensed_sweep;
  std::string source;
};

BuildOptions OptionsOf(const Release& release) {
  BuildOptions o;
  const std::string text = release.dataset().value("recipe", Json::object()).value("text", "");
  if (text.empty())
    throw Error(release.dir().string() + "/dataset.json: no recipe text to take fusion/feature options from");
  try {
    const Recipe r = ParseRecipe(text, (release.dir() / "dataset.json").string() + " (recipe)", release.dir(),
                                 release.SourceFiles().empty() ? nullptr : &release.SourceFiles());
    o.fusion = r.fusion;
    o.feature = r.feature;
    // A mesh query is sensed like the test split (else calibration, else any sensing).
    std::string sensing;
    for (const auto& s : r.splits) {
      if (s.name == "test" || (sensing.empty() && s.name == "calibration")) sensing = s.sensing;
    }
    auto it = r.sensing.find(sensing);
    if (it == r.sensing.end()) it = r.sensing.find("sensed");
    if (it == r.sensing.end() && !r.sensing.empty()) it = r.sensing.begin();
    if (it != r.sensing.end()) o.sensed_sweep = it->second.sweep;
    o.source =
        "recipe in dataset.json (sensing '" + (it == r.sensing.end() ? std::string("default") : it->first) + "')";
  } catch (const Error& e) {
    throw Error(std::string("cannot take the fusion/feature options from the release's recipe: ") + e.what());
  }
  o.fusion.threads = 0;  // a single query: use every core (results do not depend on it)
  return o;
}

PipelineResult FuseAndExtract(const Sweep& sweep, const BuildOptions& o, uint64_t seed, PipelineResult r) {
  auto t0 = Clock::now();
  // No mesh: the feature's frame comes from the field's zero crossings (Tsdf::SurfacePoints),
  // not from the extracted mesh's vertices as in the release build. Measured on
  // quickstart_ladder (107 entries): median 26, p90 54, max 98 bits of 4096 differ, and
  // every rung's pose accuracy is unchanged; 77 instead of 280 CPU-ms at 384/m (recognition_bench).
  FusionResult fused = FuseFrames(sweep.frames, sweep.intrinsics, o.fusion, DeriveSeed(seed, "fusion"),
                                  /*extract_mesh=*/false);
  const Tsdf& tsdf = *fused.tsdf;
  const Points3 surface = tsdf.SurfacePoints();
  r.timing.fusion_seconds = Since(t0);
  if (surface.rows() == 0)
    throw Error("fusion: the fused surface is empty (is the garment inside the segmentation box?)");
  t0 = Clock::now();
  const Feature f = ExtractFeature(
      surface, [&tsdf](const Vec3& p) { return tsdf.Sdf(p); }, o.feature);
  r.timing.feature_seconds = Since(t0);
  r.code.layers = f.layers;
  r.code.rings = f.rings;
  r.code.sectors = f.sectors;
  r.code.words = f.words;
  r.height = surface.col(1).maxCoeff() - surface.col(1).minCoeff();
  r.info["frames"] = static_cast<int>(sweep.frames.size());
  r.info["frames_integrated"] = fused.stats.frames_integrated;
  r.info["surface_points"] = static_cast<int>(surface.rows());
  r.info["voxels_per_metre"] = o.fusion.voxels_per_metre;
  r.info["options_from"] = o.source;
  return r;
}

}  // namespace

PipelineResult FeatureFromSweep(const Release& release, const fs::path& dir, uint64_t seed) {
  if (!fs::exists(dir / "cameras.json")) {
    throw Error(dir.string() + ": not a sweep folder (no cameras.json; expected 16-bit depth PNGs + cameras.json)");
  }
  const BuildOptions o = OptionsOf(release);
  PipelineResult r;
  const auto t0 = Clock::now();
  const Sweep sweep = ReadSweep(dir);
  r.timing.read_seconds = Since(t0);
  if (sweep.frames.empty()) throw Error(dir.string() + ": the sweep has no frames");
  return FuseAndExtract(sweep, o, seed, std::move(r));
}

PipelineResult FeatureFromMesh(const Release& release, const fs::path& file, uint64_t seed) {
  if (!fs::exists(file)) throw Error(file.string() + ": no such mesh file");
  const BuildOptions o = OptionsOf(release);
  PipelineResult r;
  auto t0 = Clock::now();
  const TriMesh mesh = ReadMesh(file);
  r.timing.read_seconds = Since(t0);
  if (mesh.NumFaces() == 0) throw Error(file.string() + ": the mesh has no faces");
  SweepOptions so = o.sensed_sweep;
  so.threads = 0;
  t0 = Clock::now();
  const Sweep sweep = SimulateSweep(mesh, so, DeriveSeed(seed, "sweep"));
  r.timing.sweep_seconds = Since(t0);
  r.info["sweep_frames"] = static_cast<int>(sweep.frames.size());
  return FuseAndExtract(sweep, o, seed, std::move(r));
}

}  // namespace drape::recognition
