// Internals shared by the release sources (not a public header).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "generator/release/release.h"

namespace drape::release_detail {

inline constexpr const char* kLockFile = ".drape.lock";
inline constexpr const char* kBuildDir = ".drape-build";
inline constexpr const char* kEntryJson = "entry.json";
// dataset.json "format_version" (absent = 1). Readers refuse newer formats.
inline constexpr int kFormatVersion = 1;
inline constexpr const char* kDigestAlgorithm =
    "drape-release-digest-v1: sha256 over '<id> <entry_digest>\\n' sorted by id; entry_digest = "
    "sha256 of canonical JSON {id,key,split,failed,failure,record,files:[[path,sha256]]}";

// Throws drape::Error (naming `what`) unless s is a safe folder name: [A-Za-z0-9._-]+,
// not starting with '.'.
void CheckSafeName(const std::string& s, const std::string& what);
// Throws unless p is a relative path of safe names separated by '/'.
void CheckSafeRelPath(const std::string& p, const std::string& what);

// JSON with object keys sorted recursively, compact.
std::string CanonicalJson(const Json& j);

// Reads entries/*/entry.json of a release folder, sorted by id. Throws drape::Error
// naming the file on a malformed one.
std::vector<Release::EntryInfo> ScanEntries(const std::filesystem::path& dir);
Release::EntryInfo ParseEntryJson(const Json& j, const std::string& where);
Json EntryJson(const Release::EntryInfo& e);

// Ordered split names: train, calibration, test first, then the rest sorted.
std::vector<std::string> OrderedSplits(const std::vector<Release::EntryInfo>& entries);
std::string Category(const Release::EntryInfo& e);
std::string AnchorLabel(const Release::EntryInfo& e);
Json Counts(const std::vector<Release::EntryInfo>& entries);

// Throws drape::Error naming `where` unless `dataset` is an object of a format this
// code reads.
void CheckFormatVersion(const Json& dataset, const std::string& where);

// SHA256SUMS: path → hex, parsed/written in coreutils format; a path listed twice or
// leaving the folder throws.
std::map<std::string, std::string> ParseSums(const std::string& text, const std::string& where);
std::string FormatSums(const std::map<std::string, std::string>& sums);

// Writes catalog.sqlite to `path` (must not exist) deterministically.
void WriteCatalog(const std::filesystem::path& path, const std::filesystem::path& release_dir, const Json& dataset_meta,
                  const std::vector<Release::EntryInfo>& entries, const std::vector<std::string>& job_keys,
                  const std::vector<std::string>& blob_files);
// Reads the entries and jobs tables.
void ReadCatalog(const std::filesystem::path& path, std::vector<Release::EntryInfo>* entries,
                 std::vector<std::string>* job_keys);

std::string DatasetCard(const Json& dataset, const std::vector<Release::EntryInfo>& entries);
std::string Gallery(const Json& dataset, const std::vector<Release::EntryInfo>& entries);

// Carried source files, release path → sha256: of a meta, or of dataset.json "sources"
// (throws drape::Error naming `where` when malformed).
std::map<std::string, std::string> SourceSums(const std::vector<SourceFile>& sources);
std::map<std::string, std::string> SourceSums(const Json& dataset, const std::string& where);
std::string SourcesSha(const std::map<std::string, std::string>& sums);

// The gallery's 3D view (viewer.cpp): whether this build carries the three.js files
// (./setup.sh installs them), whether an entry can be shown in 3D, and the files to
// write under viewer/ (paths relative to the release; meshes read from `dir`).
bool GalleryHas3d();
bool EntryHas3d(const Release::EntryInfo& e);
std::vector<std::pair<std::string, std::string>> GalleryViewerFiles(const std::filesystem::path& dir,
                                                                    const std::vector<Release::EntryInfo>& entries);

void FsyncPath(const std::filesystem::path& p);  // file or directory; best effort
std::string HostName();

}  // namespace drape::release_detail
