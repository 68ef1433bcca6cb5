// Built when the sweep/fusion/feature/recipe stages are not part of this build.
#include "common/error.h"
#include "runtime/recognition/query_pipeline.h"

namespace drape::recognition {

bool PipelineAvailable() { return false; }

PipelineResult FeatureFromSweep(const Release&, const std::filesystem::path& dir, uint64_t) {
  throw Error(dir.string() + ": sweep queries need the sweep, fusion and feature stages, which this drape was built without");
}

PipelineResult FeatureFromMesh(const Release&, const std::filesystem::path& file, uint64_t) {
  throw Error(file.string() + ": mesh queries need the sweep, fusion and feature stages, which this drape was built without");
}

}  // namespace drape::recognition
