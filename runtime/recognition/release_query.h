// One recognition query against a release, the way `drape recognize` and the Python
// package's Release.recognize answer it (one orchestration, two front ends): the query's
// feature (a stored entry's, or a sweep folder or hung mesh put through the release's own
// fusion and feature options, query_pipeline.h), its hung height for the height gates,
// the category by registration where the query has a reconstruction (category_fit.h),
// then the pose (recognizer.h), and where the matched anchor lies.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "common/json.h"
#include "generator/release/release.h"
#include "runtime/recognition/category_fit.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

struct ReleaseQuery {
  enum class Kind { kEntry, kSweep, kMesh, kFeature };
  Kind kind = Kind::kEntry;
  std::string value;    // the entry id, the sweep folder or the mesh file
  Code feature;         // kFeature: the query's bits (no height: no height gates)
  uint64_t seed = 0;    // a sweep's fusion noise, a mesh's synthetic sweep
  bool refuse = false;  // kEntry: also re-fuse its kept sweep and compare (timing, distance)
};

struct ReleaseQueryOptions {
  RecognizeOptions recognize;  // top_k, category, instances, weighted; query_height is the query's
  // The category by registration, for an entry query with a recon.ply and no category
  // given; otherwise (or false) the unweighted nearest neighbour decides.
  bool category_fit = true;
  CategoryFitOptions fit;
};

struct ReleaseQueryResult {
  Recognition recognition;
  Json query;                       // kind, id or path, truth of an entry, height, pipeline info
  Json timing;                      // seconds per stage (timing only)
  Json category_fit;                // the decision by registration (category_fit.h ToJson), or null
  std::optional<Vec3> anchor_hung;  // the matched anchor on the matched entry's hung mesh (object frame)
  // {"query", "result", "anchor_position", "timing"[, "category_fit"]}.
  Json ToJson(const Database& db) const;
};

// Throws drape::Error for an unknown or failed entry, a bad sweep or mesh, an entry
// without a kept sweep for `refuse`, or bad options.
ReleaseQueryResult RecognizeReleaseQuery(const Release& release, const Database& db, const Weights* weights,
                                         const ReleaseQuery& query, const ReleaseQueryOptions& options);

}  // namespace drape::recognition
