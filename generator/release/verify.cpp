// Verify, compare and merge releases.
#include <algorithm>
#include <map>

#include "common/error.h"
#include "common/files.h"
#include "common/hash.h"
#include "generator/release/release_internal.h"

namespace fs = std::filesystem;

namespace drape {

using namespace release_detail;

namespace {

// Hashes every file SHA256SUMS lists (missing and changed ones go into r) and lists the
// files on disk it does not; returns path → sha256 of the listed files found.
std::map<std::string, std::string> CheckListedFiles(const fs::path& dir, const std::map<std::string, std::string>& sums,
                                                    VerifyReport& r) {
  // Files on disk (regular files and symlinks), relative with '/'.
  std::map<std::string, std::string> actual;
  std::set<std::string> on_disk;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it) {
    if (it->is_directory()) continue;
    on_disk.insert(fs::relative(it->path(), dir).generic_string());
  }
  for (const auto& [path, want] : sums) {
    if (!on_disk.count(path)) {
      r.missing.push_back(path);
      continue;
    }
    const std::string have = Sha256File(dir / path);
    ++r.files_checked;
    actual[path] = have;
    if (have != want) r.changed.push_back(path);
  }
  for (const auto& p : on_disk) {
    // Not release content: the sums themselves, build timings, the lock, and the
    // runtime's calibration artifacts (bound to the digest by their own record).
    if (sums.count(p) || p == "SHA256SUMS" || p == "build.json" || p == kLockFile || p.rfind("calibration/", 0) == 0)
      continue;
    r.extra.push_back(p);
  }
  return actual;
}

// The entries' file hashes as the files are on disk now (for the digest).
void RehashEntryFiles(const fs::path& dir, const std::map<std::string, std::string>& sums,
                      const std::map<std::string, std::string>& actual, std::vector<Release::EntryInfo>& entries,
                      VerifyReport& r) {
  for (auto& e : entries) {
    for (auto& f : e.files) {
      const std::string p = "entries/" + e.id + "/" + f.path;
      auto it = actual.find(p);
      if (it != actual.end()) {
        f.sha256 = it->second;
      } else if (fs::exists(dir / p)) {
        f.sha256 = Sha256File(dir / p);
        if (!sums.count(p)) r.problems.push_back(p + ": listed in entry.json but not in SHA256SUMS");
      } else {
        f.sha256 = "missing";
        if (!sums.count(p)) r.missing.push_back(p);
      }
    }
  }
}

}  // namespace

VerifyReport Verify(const fs::path& dir) {
  VerifyReport r;
  if (!fs::is_directory(dir)) {
    r.problems.push_back(dir.string() + ": no such folder");
    return r;
  }
  if (!fs::exists(dir / "SHA256SUMS") || !fs::exists(dir / "dataset.json")) {
    r.problems.push_back(fs::exists(dir / kBuildDir) ? "unfinished build (no SHA256SUMS yet)"
                                                     : "not a finished release: SHA256SUMS or dataset.json missing");
    return r;
  }
  std::map<std::string, std::string> sums;
  try {
    sums = ParseSums(ReadFile(dir / "SHA256SUMS"), (dir / "SHA256SUMS").string());
  } catch (const Error& e) {
    r.problems.push_back(e.what());
    return r;
  }
  const std::map<std::string, std::string> actual = CheckListedFiles(dir, sums, r);

  // The digest from the entries as they are on disk now.
  Json ds;
  try {
    ds = Json::parse(ReadFile(dir / "dataset.json"));
  } catch (const std::exception& e) {
    r.problems.push_back("dataset.json: " + std::string(e.what()));
    return r;
  }
  try {
    CheckFormatVersion(ds, (dir / "dataset.json").string());
  } catch (const Error& e) {
    r.problems.push_back(e.what());
    return r;
  }
  r.expected_digest = ds.value("digest", "");
  std::vector<Release::EntryInfo> entries;
  try {
    entries = ScanEntries(dir);
  } catch (const Error& e) {
    r.problems.push_back(e.what());
    return r;
  }
  RehashEntryFiles(dir, sums, actual, entries, r);
  std::map<std::string, std::string> sources;
  try {
    sources = SourceSums(ds, (dir / "dataset.json").string());
  } catch (const Error& e) {
    r.problems.push_back(e.what());
  }
  for (auto& [p, sha] : sources) {
    auto it = actual.find(p);
    sha = it != actual.end() ? it->second : fs::exists(dir / p) ? Sha256File(dir / p) : "missing";
    if (!sums.count(p)) r.problems.push_back(p + ": a source file of the recipe not listed in SHA256SUMS");
  }
  r.actual_digest = ComputeDigest(entries, sources);
  if (r.actual_digest != r.expected_digest) {
    r.problems.push_back("release digest mismatch: dataset.json says " + r.expected_digest +
                         ", the entries on disk give " + r.actual_digest);
  }
  const int n_expected = ds.value("counts", Json::object()).value("entries", -1);
  if (n_expected != static_cast<int>(entries.size())) {
    r.problems.push_back("dataset.json counts " + std::to_string(n_expected) + " entries, found " +
                         std::to_string(entries.size()));
  }
  std::sort(r.missing.begin(), r.missing.end());
  return r;
}

VerifyReport CompareToPublished(const fs::path& dir, const fs::path& reference) {
  VerifyReport r;
  Json ref_ds, ds;
  std::map<std::string, std::string> ref_sums, sums;
  try {
    ref_ds = Json::parse(ReadFile(reference / "dataset.json"));
    ref_sums = ParseSums(ReadFile(reference / "SHA256SUMS"), (reference / "SHA256SUMS").string());
    ds = Json::parse(ReadFile(dir / "dataset.json"));
    sums = ParseSums(ReadFile(dir / "SHA256SUMS"), (dir / "SHA256SUMS").string());
  } catch (const std::exception& e) {
    r.problems.push_back(e.what());
    return r;
  }
  r.expected_digest = ref_ds.value("digest", "");
  r.actual_digest = ds.value("digest", "");
  for (const char* k : {"name", "version"}) {
    if (ref_ds.value(k, "") != ds.value(k, ""))
      r.problems.push_back(std::string(k) + ": published " + ref_ds.value(k, "") + ", this release " + ds.value(k, ""));
  }
  if (ref_ds["recipe"].value("sha256", "") != ds["recipe"].value("sha256", ""))
    r.problems.push_back("recipe sha256 differs from the published one (the recipe changed: bump the version)");
  if (r.expected_digest != r.actual_digest)
    r.problems.push_back("release digest " + r.actual_digest + " differs from the published " + r.expected_digest);
  auto content = [](const std::string& p) {
    return p == "catalog.sqlite" || p.rfind("entries/", 0) == 0 || p.rfind("sources/", 0) == 0;
  };
  for (const auto& [p, h] : ref_sums) {
    if (!content(p)) continue;
    auto it = sums.find(p);
    if (it == sums.end())
      r.missing.push_back(p);
    else if (it->second != h)
      r.changed.push_back(p);
    ++r.files_checked;
  }
  for (const auto& [p, h] : sums) {
    if (content(p) && !ref_sums.count(p)) r.extra.push_back(p);
  }
  return r;
}

ReleaseDiff CompareReleases(const Release& a, const Release& b) {
  ReleaseDiff d;
  std::map<std::string, const Release::EntryInfo*> mb;
  for (const auto& e : b.entries()) mb[e.id] = &e;
  for (const auto& e : a.entries()) {
    auto it = mb.find(e.id);
    if (it == mb.end()) {
      d.only_in_a.push_back(e.id);
      continue;
    }
    const Release::EntryInfo& f = *it->second;
    mb.erase(it);
    if (e.entry_digest == f.entry_digest) continue;
    std::vector<std::string> what;
    if (e.key != f.key) what.push_back("key");
    if (e.split != f.split) what.push_back("split");
    if (e.failed != f.failed || e.failure != f.failure) what.push_back("failure");
    if (CanonicalJson(e.record) != CanonicalJson(f.record)) {
      std::string fields;
      if (e.record.is_object() && f.record.is_object()) {
        for (auto it2 = e.record.begin(); it2 != e.record.end(); ++it2) {
          if (!f.record.contains(it2.key()) || CanonicalJson(f.record[it2.key()]) != CanonicalJson(it2.value()))
            fields += (fields.empty() ? "" : ",") + it2.key();
        }
        for (auto it2 = f.record.begin(); it2 != f.record.end(); ++it2)
          if (!e.record.contains(it2.key())) fields += (fields.empty() ? "" : ",") + it2.key();
      }
      what.push_back("record" + (fields.empty() ? std::string() : " (" + fields + ")"));
    }
    std::map<std::string, std::string> fa, fb;
    for (const auto& x : e.files) fa[x.path] = x.sha256;
    for (const auto& x : f.files) fb[x.path] = x.sha256;
    for (const auto& [p, h] : fa) {
      if (!fb.count(p))
        what.push_back(p + " only in first");
      else if (fb[p] != h)
        what.push_back(p);
    }
    for (const auto& [p, h] : fb)
      if (!fa.count(p)) what.push_back(p + " only in second");
    std::string s = e.id + ":";
    for (size_t i = 0; i < what.size(); ++i) s += (i ? ", " : " ") + what[i];
    d.differ.push_back(s);
  }
  for (const auto& [id, e] : mb) d.only_in_b.push_back(id);
  return d;
}

namespace {

// Shards must come from the same recipe, code, imported files, seed and job list.
void CheckSameBuild(const std::vector<Release>& shards, const std::vector<fs::path>& shard_dirs) {
  const Json& first = shards[0].dataset();
  const std::string name0 = shard_dirs[0].string();
  for (size_t i = 1; i < shards.size(); ++i) {
    const Json& ds = shards[i].dataset();
    const std::string who = shard_dirs[i].string();
    for (const char* k : {"name", "version", "code_version"}) {
      if (ds.value(k, "") != first.value(k, ""))
        throw Error("merge: " + who + " has " + k + " '" + ds.value(k, "") + "', " + name0 + " has '" +
                    first.value(k, "") + "': shards must come from the same recipe and code");
    }
    if (ds["recipe"].value("sha256", "") != first["recipe"].value("sha256", ""))
      throw Error("merge: " + who + " was built from a different recipe (sha256 " + ds["recipe"].value("sha256", "") +
                  ") than " + name0 + " (" + first["recipe"].value("sha256", "") + ")");
    if (ds.value("sources", Json()) != first.value("sources", Json()))
      throw Error("merge: " + who + " carries different imported files (dataset.json sources) than " + name0);
    if (ds.value("seed", Json()) != first.value("seed", Json()))
      throw Error("merge: " + who + " has a different seed than " + name0);
    if (shards[i].job_keys() != shards[0].job_keys())
      throw Error("merge: " + who + " lists a different job set than " + name0);
  }
}

// Every job in exactly one shard, every entry id in one.
void CheckEveryJobOnce(const std::vector<Release>& shards, const std::vector<fs::path>& shard_dirs,
                       const std::vector<std::string>& jobs) {
  const std::set<std::string> job_set(jobs.begin(), jobs.end());
  std::map<std::string, size_t> owner;  // key → shard
  std::map<std::string, size_t> id_owner;
  for (size_t i = 0; i < shards.size(); ++i) {
    for (const auto& e : shards[i].entries()) {
      if (!job_set.count(e.key))
        throw Error("merge: " + shard_dirs[i].string() + " holds job '" + e.key +
                    "', which is not in the recipe's job list");
      auto [it, fresh] = owner.emplace(e.key, i);
      if (!fresh)
        throw Error("merge: job '" + e.key + "' is in both " + shard_dirs[it->second].string() + " and " +
                    shard_dirs[i].string() + " (overlapping shards)");
      auto [jt, fresh_id] = id_owner.emplace(e.id, i);
      if (!fresh_id)
        throw Error("merge: entry id '" + e.id + "' is in both " + shard_dirs[jt->second].string() + " and " +
                    shard_dirs[i].string());
    }
  }
  std::vector<std::string> missing;
  for (const auto& k : jobs)
    if (!owner.count(k)) missing.push_back(k);
  if (!missing.empty()) {
    std::string msg = "merge: " + std::to_string(missing.size()) + " of " + std::to_string(jobs.size()) +
                      " jobs are in no shard (missing shards?), e.g.";
    for (size_t i = 0; i < missing.size() && i < 5; ++i) msg += (i ? ", '" : " '") + missing[i] + "'";
    throw Error(msg);
  }
}

// The whole release's meta from the first shard's dataset.json.
ReleaseMeta MergedMeta(const Release& shard0, const std::vector<std::string>& jobs) {
  const Json& first = shard0.dataset();
  ReleaseMeta meta;
  meta.name = first.value("name", "");
  meta.version = first.value("version", "");
  meta.seed = first.value("seed", Json(0)).get<uint64_t>();
  meta.recipe_text = first["recipe"].value("text", "");
  meta.recipe_sha256 = first["recipe"].value("sha256", "");
  meta.code_version = first.value("code_version", "");
  meta.description = first.value("description", "");
  meta.license = first.value("license", "");
  meta.recipe_summary = first.value("summary", Json::object());
  meta.job_keys = jobs;
  meta.catalog_blobs.clear();
  if (first.contains("catalog") && first["catalog"].contains("blobs"))
    for (const auto& b : first["catalog"]["blobs"]) meta.catalog_blobs.push_back(b.get<std::string>());

  const Json sources = first.value("sources", Json::object());  // items() must not outlive it
  for (const auto& [written, v] : sources.items())
    meta.sources.push_back({written, shard0.SourceFiles().at(written), v.value("path", ""), v.value("sha256", "")});
  return meta;
}

// A shard's entry read back for committing, its files checked against their hashes.
Entry ShardEntry(const Release& shard, const Release::EntryInfo& e, const Json& timing) {
  Entry entry;
  entry.id = e.id;
  entry.key = e.key;
  entry.split = e.split;
  entry.failed = e.failed;
  entry.failure = e.failure;
  entry.record = e.record;
  entry.timing = timing.value(e.id, Json::object());
  for (const auto& f : e.files) {
    std::string bytes = shard.ReadFile(e.id, f.path);
    if (Sha256Hex(bytes) != f.sha256)
      throw Error("merge: " + shard.EntryPath(e.id, f.path).string() +
                  " does not match its catalog hash (corrupt shard; run drape verify on it)");
    entry.files.push_back({f.path, std::move(bytes)});
  }
  return entry;
}

}  // namespace

ReleaseWriter::Summary Merge(const std::vector<fs::path>& shard_dirs, const fs::path& out) {
  if (shard_dirs.empty()) throw Error("merge: no shard folders given");
  std::vector<Release> shards;
  for (const auto& d : shard_dirs) {
    if (fs::exists(out) && fs::exists(d) && fs::equivalent(out, d))
      throw Error("merge: output " + out.string() + " is also a shard");
    shards.push_back(Release::Open(d));
  }
  CheckSameBuild(shards, shard_dirs);
  const std::vector<std::string> jobs = shards[0].job_keys();
  CheckEveryJobOnce(shards, shard_dirs, jobs);

  auto writer = ReleaseWriter::Open(out, MergedMeta(shards[0], jobs));
  const std::set<std::string> done = writer->DoneKeys();
  Json shard_info = Json::array();
  for (size_t i = 0; i < shards.size(); ++i) {
    const Json build = shards[i].build_info();
    shard_info.push_back({{"dir", fs::absolute(shard_dirs[i]).string()},
                          {"shard", shards[i].dataset().value("shard", Json())},
                          {"entries", shards[i].entries().size()},
                          {"wall_seconds", build.value("wall_seconds", Json())},
                          {"host", build.value("host", Json())}});
    const Json timing = build.value("entry_timing", Json::object());
    for (const auto& e : shards[i].entries()) {
      if (!done.count(e.key)) writer->Commit(ShardEntry(shards[i], e, timing));
    }
  }
  writer->SetBuildInfo("merged_from", shard_info);
  return writer->Finalize();
}

}  // namespace drape
