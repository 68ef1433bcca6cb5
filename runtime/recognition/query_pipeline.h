// Queries that are not stored release entries: a recorded sweep folder (depth PNGs +
// cameras.json) or a mesh. Both go through the generator's own stages with the
// release's recipe options, so a query is featurised exactly as the database was:
//   sweep folder: ReadSweep → FuseFrames(recipe fusion options, no mesh) → ExtractFeature
//                 (recipe feature options) on the field's zero crossings
//                 (Tsdf::SurfacePoints) and the TSDF — the release's entries take the
//                 mesh's vertices instead (same accuracy, see query_pipeline.cpp);
//   mesh:         a hung mesh in the object frame (gripper at the origin, y up) →
//                 SimulateSweep with the recipe's "sensed" sensing (noise and all, seeded)
//                 → the same fusion and feature. An SDF computed any other way (e.g. from
//                 the mesh directly) would not be the quantity the database holds.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "common/json.h"
#include "generator/release/release.h"
#include "runtime/recognition/matcher.h"

namespace drape::recognition {

struct PipelineTiming {
  double read_seconds = 0;     // reading the sweep / mesh
  double sweep_seconds = 0;    // synthetic sweep of a mesh query
  double fusion_seconds = 0;   // TSDF fusion (+ mesh extraction)
  double feature_seconds = 0;  // Algorithm 1
};

struct PipelineResult {
  Code code;
  PipelineTiming timing;
  double height = 0;           // hung height: the fused surface's y extent (m), for the height gates
  Json info = Json::object();  // frames, voxels, … for the output
};

// Throws drape::Error naming the folder/file on bad input.
PipelineResult FeatureFromSweep(const Release& release, const std::filesystem::path& sweep_dir, uint64_t seed);
PipelineResult FeatureFromMesh(const Release& release, const std::filesystem::path& mesh_file, uint64_t seed);

}  // namespace drape::recognition
