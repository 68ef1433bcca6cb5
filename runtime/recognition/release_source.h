// Reading what recognition needs out of a release: the database (train split), query
// splits, anchor positions, per-entry timings, and the default weights location.
//
// Labels come from each entry's record (generator/release/release.h): "category",
// "instance", "material", "anchor": {"label", "vertex", "uv"}. Features from the
// entry's feature.bin (generator/feature DecodeFeature). Failed entries are skipped
// and counted.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "generator/release/release.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

struct LoadReport {
  int loaded = 0;
  int failed_skipped = 0;  // entries the build marked failed
  double seconds = 0;      // timing only
  std::vector<std::string> warnings;
};

// Labels of one entry from its record. Throws drape::Error naming the entry and the
// missing field.
EntryLabel LabelFromEntry(const Release::EntryInfo& e);

// Decodes the entry's feature.bin. Throws drape::Error naming the entry and file if it is
// missing or corrupt.
Code LoadEntryCode(const Release& release, const Release::EntryInfo& e);

// The entry's hung height: the y extent of its recon.ply (the H of Algorithm 1, whose
// feature the build took from that mesh's vertices), m; 0 when the entry has no
// reconstruction. Throws drape::Error naming the file if it is corrupt.
double ReconHeight(const Release& release, const Release::EntryInfo& e);

// All usable entries of `split`, sorted by id, with their heights (ReconHeight).
std::vector<LabelledCode> LoadSplit(const Release& release, const std::string& split, LoadReport* report);

// The database: the train split. Throws drape::Error if the release has no usable train entry.
Database LoadDatabase(const Release& release, LoadReport* report, Kernel kernel = Kernel::kAuto);

// (instance, anchor label) → uv on the flat pattern, over every entry of the release.
AnchorUvMap AnchorUvs(const Release& release);

// Wall-clock seconds of the build's fusion and feature stages for one entry, from
// build.json "entry_timing"[id] (keys containing "fus" and "feature"); -1 when absent.
struct StageTiming {
  double fusion_seconds = -1, feature_seconds = -1;
  std::string source;
};
StageTiming EntryStageTiming(const Json& build_info, const std::string& id);

// Vertex `vertex` of the entry's hang.ply (object frame, metres); nullopt if unavailable.
std::optional<Vec3> HungVertex(const Release& release, const std::string& id, int vertex);

// <release>/calibration: where `drape calibrate` writes weights.json + weights.bin.
// Not listed in SHA256SUMS and not part of the release digest (the weights are derived
// from the release, and tied to its digest inside weights.json).
std::filesystem::path DefaultWeightsDir(const Release& release);

// The weights file a command uses (`--weights SPEC`, Python's weights=): "" = the
// release's own (DefaultWeightsDir/weights.json) when it exists, "none" = none, anything
// else the weights.json (or its folder) given. An empty path means unweighted.
std::filesystem::path ResolveWeightsPath(const Release& release, const std::string& spec);

// The queries of a split with their build timings, for Evaluate.
std::vector<EvalQuery> LoadEvalQueries(const Release& release, const std::string& split, LoadReport* report);

}  // namespace drape::recognition
