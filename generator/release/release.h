// Releases: versioned, verifiable garment databases on disk.
//
// Layout of a finished release folder (datasets/<name>/<version>/ by default):
//
//   dataset.json      name, version, seed, description, license, full recipe text + sha256,
//                     code version, job count, counts per split/category, release digest.
//                     No wall times (those are in build.json).
//   catalog.sqlite    tables `entries` (one row per entry: id, key, split, failed, failure,
//                     entry_digest, the record flattened into typed columns, record_json,
//                     files_json, feature BLOB), `files` (id, path, sha256, size),
//                     `jobs` (position, key, id), `meta` (key, value). Built
//                     deterministically from the entries at Finalize: same bytes for any
//                     thread count, shard layout or resume history.
//   entries/<id>/     entry.json (id, key, split, failed, failure, record, files with
//                     sha256 + size) and the entry's files (hang.ply, recon.ply, sdf.vdb,
//                     feature.bin, preview.png, sweep/…).
//   README.md         dataset card (Hugging-Face YAML front matter + description).
//   index.html        gallery, one card per entry; works from file:// offline.
//   SHA256SUMS        `sha256sum -c SHA256SUMS` verifies every file above (relative paths).
//   build.json        wall times, host, per-entry timing. NOT hashed, NOT in SHA256SUMS.
//
// While a build runs the folder also holds `.drape.lock` (flock; released by the kernel
// if the process dies) and `.drape-build/` (meta.json, journal.jsonl, staging/). Both are
// gone once Finalize returns. SHA256SUMS is written last: its presence marks "finished".
//
// The release digest (dataset.json "digest") is defined over canonical entry content only:
//   entry_digest = sha256(canonical JSON of {id, key, split, failed, failure,
//                          record (keys sorted recursively), files: [[path, sha256]...] sorted})
//   digest       = sha256 over "<id> <entry_digest>\n" for all entries sorted by id.
//   A release whose recipe imports files (meshes and the files they refer to, anchors
//   sidecars) carries copies of them under sources/ (listed in dataset.json "sources",
//   in SHA256SUMS), and the digest then also covers "source <path> <sha256>\n" for
//   each, sorted by path; a release without imports has the same digest as before
//   sources existed.
// Never over timestamps, timings, SQLite page layout, code version or shard layout.
//
// Record keys the writer understands (all optional; anything else is kept and
// flattened into catalog columns as well, nested keys joined with '_'):
//   "category": "shirt", "garment": "long_sleeve_shirt", "instance": "shirt_0",
//   "material": "tshirt", "anchor": {"label": "left_cuff", "vertex": 12, "uv": [u, v]},
//   "grasp_offset": [x, y, z] (metres), "seed": uint64,
//   "hang": {...stats}, "sweep": {...}, "fusion": {"recon_to_truth_mean": m, ...},
//   "feature": {...}.
// The gallery shows fusion.recon_to_truth_mean (in mm) as "fusion error"; `drape ls
// --anchor` filters on anchor.label; `--category` on category.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "common/json.h"
#include "generator/release/entry.h"

namespace drape {

// A file the recipe reads (an imported mesh, its companions, an anchors sidecar), copied
// into the release.
struct SourceFile {
  std::string recipe_path;     // as written in the recipe (key of dataset.json "sources")
  std::filesystem::path file;  // where the build reads it from
  std::string release_path;    // "sources/…" inside the release
  std::string sha256;          // of the bytes (ReleaseWriter::Open fills it if empty)
};

// Release paths for a recipe's imported files: "sources/<path as written>" when that is
// a plain relative path inside the recipe folder, else "sources/<file name>" (then
// "sources/2/<file name>", … on a clash). File names are kept: a garment's default name
// is its file's stem. The files a mesh refers to (garments/mesh_companions.h: a .gltf's
// .bin and images, an .obj's .mtl and textures) follow it, at the same place relative
// to the copy (keyed by the recipe folder's path to them); one that would land on
// another file's place throws drape::Error.
std::vector<SourceFile> PlanSources(const std::vector<std::pair<std::string, std::filesystem::path>>& files);

// What a build knows about the release it writes.
struct ReleaseMeta {
  std::string name;     // e.g. "quickstart"; [A-Za-z0-9._-]
  std::string version;  // semantic "MAJOR.MINOR.PATCH" (TFDS meaning)
  uint64_t seed = 0;
  std::string recipe_text;               // the full recipe file, verbatim
  std::string recipe_sha256;             // of recipe_text (filled in if empty)
  std::string code_version;              // e.g. git describe; recorded, never hashed into the digest
  std::string description;               // free text for the card
  std::string license = "cc-by-4.0";     // Hugging Face license identifier
  Json recipe_summary = Json::object();  // anything else for dataset.json / the card
  // Every job of the recipe, in recipe order (keys unique).
  std::vector<std::string> job_keys;
  // The jobs this writer must produce (a shard's subset, chosen by the build);
  // empty = all of job_keys.
  std::vector<std::string> shard_keys;
  int shard_index = 0, shard_count = 1;
  // Entry files whose bytes are also stored as BLOB columns in catalog.sqlite's
  // `entries` table (column name = file stem, e.g. "feature").
  std::vector<std::string> catalog_blobs = {"feature.bin"};
  // Imported files the recipe names (empty for template-only recipes).
  std::vector<SourceFile> sources;

  void Validate() const;  // throws drape::Error naming the bad field
};

// Writes a release. Thread-safe Commit; atomic per entry; resumable after any crash.
class ReleaseWriter {
 public:
  // Takes the folder's lock and prepares it:
  //  - missing/empty folder: a new build;
  //  - an unfinished build (.drape-build/meta.json): resumed if its recipe sha256, code
  //    version and shard match, else refused (delete the folder or use the same inputs);
  //    leftover staging folders are removed, half-written entries are never done;
  //  - a finished release of the same version: refused if the recipe or code differs
  //    ("bump the version"); otherwise every job is already done, Commit throws and
  //    Finalize only reports the release (nothing is rewritten, build.json kept);
  //  - a folder holding only a published reference (dataset.json + SHA256SUMS, as
  //    committed under datasets/): built into; Finalize reports whether the digest matches;
  //  - anything else non-empty: refused.
  // A second writer on a locked folder (this or another process) is refused with a
  // message naming the holder's pid and host. `resume` = the caller expects an unfinished
  // build to continue (error if the folder does not exist); without it an unfinished
  // build is resumed anyway.
  static std::unique_ptr<ReleaseWriter> Open(const std::filesystem::path& dir, const ReleaseMeta& meta,
                                             bool resume = false);
  ~ReleaseWriter();  // releases the lock; keeps progress for a later resume
  ReleaseWriter(const ReleaseWriter&) = delete;
  ReleaseWriter& operator=(const ReleaseWriter&) = delete;

  // Keys of jobs already committed (failed ones included: failures are deterministic).
  std::set<std::string> DoneKeys() const;

  // Stores one entry: files to a staging folder, fsync, rename to entries/<id>, then a
  // journal line with its timing. Thread-safe. Throws drape::Error on an unknown or
  // already committed key, a duplicate id, an unsafe id/path, or the reserved file name
  // "entry.json".
  void Commit(const Entry& entry);

  struct Summary {
    std::string digest;
    int entries = 0, failed = 0;
    Json counts;                    // as in dataset.json "counts"
    uint64_t bytes = 0;             // on disk, all listed files
    double wall_seconds = 0;        // since the first Open of this build (timing only)
    std::string published_digest;   // digest of a published reference found in the folder
    bool matches_published = true;  // false if a reference was found and differs
  };
  // Requires every expected job committed (else drape::Error naming how many and the
  // first missing keys). Writes catalog.sqlite, README.md, index.html, build.json,
  // dataset.json, SHA256SUMS (last), removes .drape-build and releases the lock.
  Summary Finalize();

  // Adds a top-level field to build.json (timing/machine facts; never hashed), e.g.
  // "threads", "stage_seconds", "mpi_ranks".
  void SetBuildInfo(const std::string& key, Json value);

  const std::filesystem::path& dir() const;

 private:
  struct Impl;
  explicit ReleaseWriter(std::unique_ptr<Impl> impl);
  static std::unique_ptr<ReleaseWriter> OpenLocked(std::unique_ptr<Impl>& impl, const ReleaseMeta& meta, bool resume);
  std::unique_ptr<Impl> impl_;
};

// Reads a finished release (or shard).
class Release {
 public:
  struct FileInfo {
    std::string path;  // relative to entries/<id>/
    std::string sha256;
    uint64_t size = 0;
  };
  struct EntryInfo {
    std::string id, key, split;
    bool failed = false;
    std::string failure;
    Json record;
    std::vector<FileInfo> files;  // sorted by path
    std::string entry_digest;
  };

  // Throws drape::Error if dir is not a finished release.
  static Release Open(const std::filesystem::path& dir);

  const Json& dataset() const { return dataset_; }
  const std::vector<EntryInfo>& entries() const { return entries_; }  // sorted by id
  // The recipe's imported files in this release: path as written in the recipe → file
  // (for ParseRecipe, so a moved release re-reads its own copies).
  const std::map<std::string, std::filesystem::path>& SourceFiles() const { return sources_; }
  const EntryInfo* Find(const std::string& id) const;
  std::vector<std::string> job_keys() const { return job_keys_; }  // recipe order
  std::string ReadFile(const std::string& id, const std::string& path) const;
  std::filesystem::path EntryPath(const std::string& id, const std::string& path = "") const;
  std::string digest() const;
  const std::filesystem::path& dir() const { return dir_; }
  Json build_info() const;  // build.json, or {} if absent

 private:
  std::filesystem::path dir_;
  Json dataset_;
  std::vector<EntryInfo> entries_;
  std::vector<std::string> job_keys_;
  std::map<std::string, std::filesystem::path> sources_;
};

// Canonical per-entry digest and release digest (see the top of this file).
std::string EntryDigest(const std::string& id, const std::string& key, const std::string& split, bool failed,
                        const std::string& failure, const Json& record, const std::vector<Release::FileInfo>& files);
// `sources`: release path → sha256 of the release's carried source files.
std::string ComputeDigest(const std::vector<Release::EntryInfo>& entries,
                          const std::map<std::string, std::string>& sources = {});

struct VerifyReport {
  std::vector<std::string> missing;   // listed in SHA256SUMS, not on disk
  std::vector<std::string> extra;     // on disk, not listed
  std::vector<std::string> changed;   // hash differs
  std::vector<std::string> problems;  // anything else (digest mismatch, bad entry.json, …)
  std::string expected_digest, actual_digest;
  int files_checked = 0;
  bool ok() const { return missing.empty() && extra.empty() && changed.empty() && problems.empty(); }
};
// Hashes every file against SHA256SUMS, looks for unlisted files, recomputes the digest
// from entries/*/entry.json and the files on disk and compares it with dataset.json.
VerifyReport Verify(const std::filesystem::path& dir);
// Compares a release with a published reference (a folder with the committed
// dataset.json + SHA256SUMS): digest and content files (entries/, catalog.sqlite).
// dataset.json/README.md/index.html carry the code version, so they may differ.
VerifyReport CompareToPublished(const std::filesystem::path& dir, const std::filesystem::path& reference);

// Entry-by-entry comparison of two releases (for verify --rebuild, merge tests).
struct ReleaseDiff {
  std::vector<std::string> only_in_a, only_in_b;  // ids
  std::vector<std::string> differ;                // "id: what differs"
  bool same() const { return only_in_a.empty() && only_in_b.empty() && differ.empty(); }
};
ReleaseDiff CompareReleases(const Release& a, const Release& b);

// Merges finished shard releases into `out`: checks the same name, version, recipe
// sha256, code version and job list, and that every job is covered exactly once; copies
// the entries (checking their hashes) and finalizes. The result equals a one-process
// build (same digest and SHA256SUMS). Throws drape::Error naming the offending shard/key.
ReleaseWriter::Summary Merge(const std::vector<std::filesystem::path>& shards, const std::filesystem::path& out);

// Hook for `drape verify --rebuild`: the build library (or cli/cmd_build.cpp) installs a
// function that rebuilds the release's recipe into `out` (a fresh temporary folder) with
// `threads` threads. Unset = --rebuild unavailable.
struct RebuildRequest {
  std::filesystem::path release;      // the release to check
  std::filesystem::path recipe_path;  // --recipe override; empty = use dataset.json's recipe text
  std::filesystem::path out;          // temporary folder to build into
  int threads = 0;
};
using Rebuilder = std::function<void(const RebuildRequest&)>;
void SetRebuilder(Rebuilder fn);
const Rebuilder& GetRebuilder();

}  // namespace drape
