// Release writer and reader: atomic entries, lock, journal, resume, finalize.
#include "generator/release/release.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <sstream>

#include "common/error.h"
#include "common/files.h"
#include "common/hash.h"
#include "common/unique_fd.h"
#include "garments/mesh_companions.h"
#include "generator/release/release_internal.h"

namespace fs = std::filesystem;

namespace drape {
namespace release_detail {

void CheckSafeName(const std::string& s, const std::string& what) {
  bool ok = !s.empty() && s.size() <= 200 && s[0] != '.';
  for (char c : s) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) ok = false;
  }
  if (!ok) {
    throw Error(what + " '" + s + "' is not a safe name (use letters, digits, '.', '_', '-'; not starting with '.')");
  }
}

void CheckSafeRelPath(const std::string& p, const std::string& what) {
  if (p.empty()) throw Error(what + ": empty path");
  size_t start = 0;
  while (true) {
    const size_t slash = p.find('/', start);
    const std::string part = p.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
    CheckSafeName(part, what + " path '" + p + "' component");
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
}

// nlohmann::json (unlike our insertion-ordered Json) keeps object keys in a std::map,
// sorted by byte order, so converting and dumping gives the canonical form.
std::string CanonicalJson(const Json& j) { return nlohmann::json(j).dump(); }

Json EntryJson(const Release::EntryInfo& e) {
  Json files = Json::array();
  for (const auto& f : e.files) files.push_back({{"path", f.path}, {"sha256", f.sha256}, {"size", f.size}});
  return Json{{"id", e.id},           {"key", e.key},       {"split", e.split}, {"failed", e.failed},
              {"failure", e.failure}, {"record", e.record}, {"files", files},   {"entry_digest", e.entry_digest}};
}

Release::EntryInfo ParseEntryJson(const Json& j, const std::string& where) {
  try {
    Release::EntryInfo e;
    e.id = j.at("id").get<std::string>();
    e.key = j.at("key").get<std::string>();
    e.split = j.at("split").get<std::string>();
    e.failed = j.at("failed").get<bool>();
    e.failure = j.at("failure").get<std::string>();
    e.record = j.at("record");
    for (const auto& f : j.at("files")) {
      e.files.push_back(
          {f.at("path").get<std::string>(), f.at("sha256").get<std::string>(), f.at("size").get<uint64_t>()});
    }
    std::sort(e.files.begin(), e.files.end(), [](auto& a, auto& b) { return a.path < b.path; });
    e.entry_digest = j.value("entry_digest", std::string());
    return e;
  } catch (const Json::exception& ex) {
    throw Error(where + ": malformed entry: " + ex.what());
  }
}

std::vector<Release::EntryInfo> ScanEntries(const fs::path& dir) {
  std::vector<Release::EntryInfo> out;
  const fs::path root = dir / "entries";
  if (!fs::exists(root)) return out;
  for (const auto& d : fs::directory_iterator(root)) {
    if (!d.is_directory()) continue;
    const fs::path ej = d.path() / kEntryJson;
    Json j;
    try {
      j = Json::parse(ReadFile(ej));
    } catch (const Json::exception& ex) {
      throw Error(ej.string() + ": " + ex.what());
    }
    out.push_back(ParseEntryJson(j, ej.string()));
    if (out.back().id != d.path().filename().string()) {
      throw Error(ej.string() + ": id '" + out.back().id + "' does not match its folder");
    }
  }
  std::sort(out.begin(), out.end(), [](auto& a, auto& b) { return a.id < b.id; });
  std::map<std::string, std::string> id_of_key;
  for (const auto& e : out) {
    auto [it, fresh] = id_of_key.emplace(e.key, e.id);
    if (!fresh)
      throw Error((root / e.id / kEntryJson).string() + ": job '" + e.key + "' is also entry '" + it->second +
                  "' (an entry listed twice)");
  }
  return out;
}

std::vector<std::string> OrderedSplits(const std::vector<Release::EntryInfo>& entries) {
  std::set<std::string> seen;
  for (const auto& e : entries) seen.insert(e.split);
  std::vector<std::string> out;
  for (const char* s : {"train", "calibration", "test"}) {
    if (seen.erase(s)) out.push_back(s);
  }
  out.insert(out.end(), seen.begin(), seen.end());
  return out;
}

std::string Category(const Release::EntryInfo& e) {
  if (e.record.is_object() && e.record.contains("category") && e.record["category"].is_string())
    return e.record["category"].get<std::string>();
  return "unknown";
}

std::string AnchorLabel(const Release::EntryInfo& e) {
  if (e.record.is_object() && e.record.contains("anchor")) {
    const Json& a = e.record["anchor"];
    if (a.is_string()) return a.get<std::string>();
    if (a.is_object() && a.contains("label") && a["label"].is_string()) return a["label"].get<std::string>();
  }
  return "";
}

Json Counts(const std::vector<Release::EntryInfo>& entries) {
  Json splits = Json::object(), categories = Json::object(), split_categories = Json::object();
  std::map<std::string, int> cat;
  std::map<std::string, std::map<std::string, int>> sc;
  int failed = 0;
  for (const auto& e : entries) {
    ++cat[Category(e)];
    ++sc[e.split][Category(e)];
    failed += e.failed;
  }
  for (const auto& s : OrderedSplits(entries)) {
    int n = 0;
    Json per = Json::object();
    for (const auto& [c, k] : sc[s]) {
      per[c] = k;
      n += k;
    }
    splits[s] = n;
    split_categories[s] = per;
  }
  for (const auto& [c, k] : cat) categories[c] = k;
  return Json{{"entries", entries.size()},
              {"failed", failed},
              {"splits", splits},
              {"categories", categories},
              {"split_categories", split_categories}};
}

void CheckFormatVersion(const Json& dataset, const std::string& where) {
  if (!dataset.is_object()) throw Error(where + ": expected a JSON object");
  const Json v = dataset.value("format_version", Json(1));
  if (!v.is_number_integer() || v.get<int64_t>() < 1)
    throw Error(where + ": format_version must be a positive integer, got " + v.dump());
  if (v.get<int64_t>() > kFormatVersion)
    throw Error(where + ": release format " + v.dump() + " was written by a newer drape; this drape reads format " +
                std::to_string(kFormatVersion) + " and older (upgrade drape)");
}

std::map<std::string, std::string> ParseSums(const std::string& text, const std::string& where) {
  std::map<std::string, std::string> out;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    if (line.size() < 67 || line[64] != ' ' || (line[65] != ' ' && line[65] != '*')) {
      throw Error(where + ":" + std::to_string(n) + ": not a sha256sum line");
    }
    const std::string path = line.substr(66);
    CheckSafeRelPath(path, where + ":" + std::to_string(n));
    if (!out.emplace(path, line.substr(0, 64)).second)
      throw Error(where + ":" + std::to_string(n) + ": '" + path + "' is listed twice");
  }
  return out;
}

std::string FormatSums(const std::map<std::string, std::string>& sums) {
  std::string out;
  for (const auto& [p, h] : sums) out += h + "  " + p + "\n";
  return out;
}

void FsyncPath(const fs::path& p) {
  const UniqueFd fd(::open(p.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.valid()) ::fsync(fd.get());
}

std::string HostName() {
  char buf[256] = {0};
  if (::gethostname(buf, sizeof(buf) - 1) != 0) return "unknown";
  return buf;
}

}  // namespace release_detail

using namespace release_detail;

// ---------------------------------------------------------------- digest

std::string EntryDigest(const std::string& id, const std::string& key, const std::string& split, bool failed,
                        const std::string& failure, const Json& record, const std::vector<Release::FileInfo>& files) {
  std::vector<std::pair<std::string, std::string>> fl;
  fl.reserve(files.size());
  for (const auto& f : files) fl.emplace_back(f.path, f.sha256);
  std::sort(fl.begin(), fl.end());
  Json jf = Json::array();
  for (const auto& [p, h] : fl) jf.push_back(Json::array({p, h}));
  const Json canon{{"id", id},           {"key", key},       {"split", split}, {"failed", failed},
                   {"failure", failure}, {"record", record}, {"files", jf}};
  return Sha256Hex(CanonicalJson(canon));
}

std::string ComputeDigest(const std::vector<Release::EntryInfo>& entries,
                          const std::map<std::string, std::string>& sources) {
  std::vector<std::pair<std::string, std::string>> lines;
  lines.reserve(entries.size());
  for (const auto& e : entries) {
    lines.emplace_back(e.id, EntryDigest(e.id, e.key, e.split, e.failed, e.failure, e.record, e.files));
  }
  std::sort(lines.begin(), lines.end());
  Sha256 h;
  for (const auto& [id, d] : lines) h.Update(id + " " + d + "\n");
  for (const auto& [path, sha] : sources) h.Update("source " + path + " " + sha + "\n");  // sorted by path
  return h.HexDigest();
}

std::vector<SourceFile> PlanSources(const std::vector<std::pair<std::string, fs::path>>& files) {
  std::vector<SourceFile> out;
  std::set<std::string> used;
  std::map<std::string, std::string> by_written;
  for (const auto& [written, file] : files) {
    if (by_written.count(written)) continue;  // the same file named twice
    const fs::path w = fs::path(written).lexically_normal();
    std::string rel = w.generic_string();
    const bool plain = !w.is_absolute() && !rel.empty() && rel.rfind("..", 0) != 0;
    if (!plain) rel = file.filename().string();
    std::string path = "sources/" + rel;
    for (int n = 2; used.count(path); ++n) path = "sources/" + std::to_string(n) + "/" + file.filename().string();
    used.insert(path);
    by_written[written] = path;
    out.push_back({written, file, path, ""});
  }
  // Companions (a .gltf's .bin, an .obj's .mtl and textures) keep their place beside
  // the copy of the mesh, so that the copy reads as the original did.
  const size_t named = out.size();
  for (size_t i = 0; i < named; ++i) {
    const SourceFile mesh = out[i];
    for (const std::string& rel : MeshCompanions(mesh.file)) {
      const std::string written = (fs::path(mesh.recipe_path).parent_path() / rel).lexically_normal().generic_string();
      const std::string path = (fs::path(mesh.release_path).parent_path() / rel).lexically_normal().generic_string();
      const auto it = by_written.find(written);
      if (it != by_written.end() && it->second == path) continue;  // shared by two meshes
      if (it != by_written.end() || used.count(path))
        throw Error(mesh.file.string() + ": its companion '" + rel + "' would be copied to " + path +
                    ", where the release already carries another file");
      used.insert(path);
      by_written[written] = path;
      out.push_back({written, mesh.file.parent_path() / rel, path, ""});
    }
  }
  return out;
}

namespace release_detail {
// release path → sha256 of a meta's sources.
std::map<std::string, std::string> SourceSums(const std::vector<SourceFile>& sources) {
  std::map<std::string, std::string> m;
  for (const auto& f : sources) m[f.release_path] = f.sha256;
  return m;
}

// The same from dataset.json "sources" ({recipe path: {"path", "sha256"}}).
std::map<std::string, std::string> SourceSums(const Json& ds, const std::string& where) {
  std::map<std::string, std::string> m;
  const Json src = ds.value("sources", Json::object());
  if (!src.is_object()) throw Error(where + ": \"sources\" must be an object");
  for (auto it = src.begin(); it != src.end(); ++it) {
    if (!it.value().is_object() || !it.value().value("path", Json()).is_string() ||
        !it.value().value("sha256", Json()).is_string())
      throw Error(where + ": sources['" + it.key() + "'] needs \"path\" and \"sha256\" strings");
    const std::string path = it.value()["path"].get<std::string>();
    CheckSafeRelPath(path, where + ": sources['" + it.key() + "'].path");
    m[path] = it.value()["sha256"].get<std::string>();
  }
  return m;
}

std::string SourcesSha(const std::map<std::string, std::string>& sums) {
  Sha256 h;
  for (const auto& [p, sha] : sums) h.Update(p + " " + sha + "\n");
  return h.HexDigest();
}
}  // namespace release_detail

// ---------------------------------------------------------------- meta

void ReleaseMeta::Validate() const {
  CheckSafeName(name, "ReleaseMeta.name");
  {
    int dots = 0;
    bool ok = !version.empty() && std::isdigit(static_cast<unsigned char>(version.front())) &&
              std::isdigit(static_cast<unsigned char>(version.back()));
    for (char c : version) {
      if (c == '.')
        ++dots;
      else if (!std::isdigit(static_cast<unsigned char>(c)))
        ok = false;
    }
    if (!ok || dots != 2 || version.find("..") != std::string::npos) {
      throw Error("ReleaseMeta.version '" + version + "' is not MAJOR.MINOR.PATCH");
    }
  }
  if (job_keys.empty()) throw Error("ReleaseMeta.job_keys: empty (a release needs at least one job)");
  std::set<std::string> keys;
  for (const auto& k : job_keys) {
    if (k.empty() || k.find('\n') != std::string::npos)
      throw Error("ReleaseMeta.job_keys: empty key or key with a newline");
    if (!keys.insert(k).second) throw Error("ReleaseMeta.job_keys: duplicate key '" + k + "'");
  }
  std::set<std::string> sk;
  for (const auto& k : shard_keys) {
    if (!keys.count(k)) throw Error("ReleaseMeta.shard_keys: '" + k + "' is not in job_keys");
    if (!sk.insert(k).second) throw Error("ReleaseMeta.shard_keys: duplicate key '" + k + "'");
  }
  if (shard_count < 1 || shard_index < 0 || shard_index >= shard_count)
    throw Error("ReleaseMeta.shard_index/shard_count: " + std::to_string(shard_index) + "/" +
                std::to_string(shard_count) + " out of range");
  if (!recipe_sha256.empty() && recipe_sha256 != Sha256Hex(recipe_text))
    throw Error("ReleaseMeta.recipe_sha256 does not match recipe_text");
  for (const auto& b : catalog_blobs) CheckSafeRelPath(b, "ReleaseMeta.catalog_blobs");
  std::set<std::string> written, paths;
  for (const auto& f : sources) {
    CheckSafeRelPath(f.release_path, "ReleaseMeta.sources");
    if (f.release_path.rfind("sources/", 0) != 0)
      throw Error("ReleaseMeta.sources: '" + f.release_path + "' is not under sources/");
    if (!written.insert(f.recipe_path).second || !paths.insert(f.release_path).second)
      throw Error("ReleaseMeta.sources: '" + f.recipe_path + "' listed twice");
  }
}

namespace {

std::string JobKeysSha(const std::vector<std::string>& keys) {
  Sha256 h;
  for (const auto& k : keys) h.Update(k + "\n");
  return h.HexDigest();
}

// The fields that must agree for a build to be resumed or a finished release reused.
Json IdentityJson(const ReleaseMeta& m) {
  Json id{{"name", m.name},
          {"version", m.version},
          {"seed", m.seed},
          {"recipe_sha256", m.recipe_sha256},
          {"code_version", m.code_version},
          {"jobs_sha256", JobKeysSha(m.job_keys)},
          {"shard_index", m.shard_index},
          {"shard_count", m.shard_count}};
  if (!m.sources.empty()) id["sources_sha256"] = SourcesSha(SourceSums(m.sources));
  return id;
}

std::string NowUtc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

double NowSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

void WriteAll(int fd, std::string_view bytes, const std::string& what) {
  size_t off = 0;
  while (off < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + off, bytes.size() - off);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error(what + ": write failed: " + std::strerror(errno));
    }
    off += static_cast<size_t>(n);
  }
}

void WriteFileNew(const fs::path& p, std::string_view bytes) {
  const UniqueFd fd(::open(p.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
  if (!fd.valid()) throw Error(p.string() + ": cannot create: " + std::strerror(errno));
  WriteAll(fd.get(), bytes, p.string());
}

bool DirHasOnly(const fs::path& dir, const std::set<std::string>& allowed) {
  for (const auto& d : fs::directory_iterator(dir)) {
    if (!allowed.count(d.path().filename().string())) return false;
  }
  return true;
}

}  // namespace

// ---------------------------------------------------------------- writer

struct ReleaseWriter::Impl {
  fs::path dir;
  ReleaseMeta meta;
  int lock_fd = -1;
  int journal_fd = -1;
  mutable std::mutex mu;
  std::set<std::string> expected;     // keys this writer must produce
  std::set<std::string> done;         // committed keys
  std::set<std::string> in_progress;  // keys being committed
  std::map<std::string, std::string> id_of_key;
  std::set<std::string> ids;
  std::atomic<uint64_t> staging_seq{0};
  Json build_info = Json::object();
  std::string started_utc;
  double started_seconds = 0;
  std::string published_digest;
  bool already_finished = false;  // opened on a finished release with the same inputs

  fs::path build_dir() const { return dir / kBuildDir; }

  ~Impl() {
    if (already_finished) DropLock();  // a finished release keeps no lock file
    if (journal_fd >= 0) ::close(journal_fd);
    if (lock_fd >= 0) ::close(lock_fd);  // the kernel drops the flock with the descriptor
  }

  void TakeLock() {
    const fs::path lp = dir / kLockFile;
    // Retry if the file we locked was unlinked meanwhile (a finishing build removes it):
    // the lock must be on the file that is at the path now.
    for (int attempt = 0;; ++attempt) {
      lock_fd = ::open(lp.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
      if (lock_fd < 0) throw Error(lp.string() + ": cannot open lock file: " + std::strerror(errno));
      if (::flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
        std::string holder;
        try {
          const Json h = Json::parse(ReadFile(lp));
          holder = "pid " + std::to_string(h.value("pid", 0)) + " on host " + h.value("host", std::string("?")) +
                   " (since " + h.value("started", std::string("?")) + ")";
        } catch (...) {
          holder = "another process";
        }
        ::close(lock_fd);
        lock_fd = -1;
        throw Error(dir.string() + ": another build is writing this release: " + holder + " holds " + lp.string() +
                    ". Wait for it to finish, or stop it; a dead build's lock is released "
                    "automatically.");
      }
      struct stat a {
      }, b{};
      if (::fstat(lock_fd, &a) == 0 && ::stat(lp.c_str(), &b) == 0 && a.st_ino == b.st_ino && a.st_dev == b.st_dev)
        break;
      ::close(lock_fd);
      lock_fd = -1;
      if (attempt > 10) throw Error(lp.string() + ": lock file keeps changing; is another build starting?");
    }
    const std::string info = Json{{"pid", ::getpid()}, {"host", HostName()}, {"started", NowUtc()}}.dump() + "\n";
    if (::ftruncate(lock_fd, 0) == 0) {
      ::lseek(lock_fd, 0, SEEK_SET);
      WriteAll(lock_fd, info, lp.string());
    }
  }

  // Gives up the lock and removes the lock file (while still holding it).
  void DropLock() {
    if (lock_fd < 0) return;
    ::unlink((dir / kLockFile).c_str());
    ::close(lock_fd);
    lock_fd = -1;
  }

  // Loads committed entries from entries/*/entry.json; removes broken folders.
  void LoadDone() {
    const fs::path root = dir / "entries";
    if (!fs::exists(root)) return;
    for (const auto& d : fs::directory_iterator(root)) {
      const fs::path ej = d.path() / kEntryJson;
      bool ok = d.is_directory() && fs::exists(ej);
      Release::EntryInfo e;
      if (ok) {
        try {
          e = ParseEntryJson(Json::parse(ReadFile(ej)), ej.string());
          ok = e.id == d.path().filename().string();
          for (const auto& f : e.files) {
            const fs::path fp = d.path() / f.path;
            if (!fs::exists(fp) || fs::file_size(fp) != f.size) ok = false;
          }
        } catch (const std::exception&) {
          ok = false;
        }
      }
      if (!ok) {
        // Only a complete staging folder is ever renamed here, so this is damage from
        // outside the writer: redo the job rather than trust it.
        fs::remove_all(d.path());
        continue;
      }
      if (!expected.count(e.key)) {
        throw Error(ej.string() + ": entry for job '" + e.key +
                    "', which this build does not produce (different recipe or shard?)");
      }
      if (!done.insert(e.key).second) throw Error(ej.string() + ": job '" + e.key + "' stored twice");
      id_of_key[e.key] = e.id;
      ids.insert(e.id);
    }
  }

  void OpenJournal() {
    const fs::path jp = build_dir() / "journal.jsonl";
    // A line cut by a crash is completed with a newline so later lines stay parseable.
    if (fs::exists(jp)) {
      const std::string text = ReadFile(jp);
      if (!text.empty() && text.back() != '\n') {
        const int fd = ::open(jp.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
        if (fd >= 0) {
          WriteAll(fd, "\n", jp.string());
          ::close(fd);
        }
      }
    }
    journal_fd = ::open(jp.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (journal_fd < 0) throw Error(jp.string() + ": cannot open journal: " + std::strerror(errno));
  }

  std::map<std::string, Json> ReadJournalTimings() const {
    std::map<std::string, Json> out;
    const fs::path jp = build_dir() / "journal.jsonl";
    if (!fs::exists(jp)) return out;
    std::istringstream in(ReadFile(jp));
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty()) continue;
      try {
        const Json j = Json::parse(line);
        out[j.at("id").get<std::string>()] = j.value("timing", Json::object());
      } catch (const std::exception&) {
        // a line cut by a crash: its entry is on disk, only its timing is lost
      }
    }
    return out;
  }
};

ReleaseWriter::ReleaseWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ReleaseWriter::~ReleaseWriter() = default;
const fs::path& ReleaseWriter::dir() const { return impl_->dir; }

void ReleaseWriter::SetBuildInfo(const std::string& key, Json value) {
  std::lock_guard<std::mutex> g(impl_->mu);
  impl_->build_info[key] = std::move(value);
}

std::unique_ptr<ReleaseWriter> ReleaseWriter::Open(const fs::path& dir_in, const ReleaseMeta& meta_in, bool resume) {
  ReleaseMeta meta = meta_in;
  if (meta.recipe_sha256.empty()) meta.recipe_sha256 = Sha256Hex(meta.recipe_text);
  for (auto& f : meta.sources)
    if (f.sha256.empty()) f.sha256 = Sha256File(f.file);
  meta.Validate();
  const fs::path dir = dir_in.empty() ? fs::path(".") : dir_in;
  const bool existed = fs::exists(dir);
  if (existed && !fs::is_directory(dir)) throw Error(dir.string() + ": exists and is not a folder");
  if (resume && !existed) throw Error(dir.string() + ": nothing to resume (the folder does not exist)");
  // Never leave a lock file in a folder that is not ours.
  if (existed && !fs::exists(dir / kBuildDir) && !fs::exists(dir / "SHA256SUMS") && !DirHasOnly(dir, {kLockFile})) {
    throw Error(dir.string() + ": folder is not empty and is not a drape release; refusing to write into it");
  }
  fs::create_directories(dir);

  auto impl = std::make_unique<Impl>();
  impl->dir = dir;
  impl->meta = meta;
  impl->TakeLock();
  try {
    return OpenLocked(impl, meta, resume);
  } catch (...) {
    // Refused after locking: leave the folder as it was (minus our lock file).
    if (impl) impl->DropLock();
    throw;
  }
}

namespace {

// The identity fields where `have` differs from this build's, one line each after
// `what`; empty when all agree.
std::string IdentityDiff(const Json& identity, const Json& have, const std::string& what) {
  std::string diffs;
  for (auto it = identity.begin(); it != identity.end(); ++it) {
    if (!have.contains(it.key()) || have[it.key()] != it.value()) {
      diffs += "\n  " + it.key() + ": folder has " +
               (have.contains(it.key()) ? have[it.key()].dump() : std::string("nothing")) + ", this build has " +
               it.value().dump();
    }
  }
  return diffs.empty() ? std::string() : what + diffs;
}

// IdentityJson's fields as a finished release's dataset.json records them.
Json FinishedIdentity(const Json& ds, const std::string& where) {
  Json have{{"name", ds.value("name", "")},
            {"version", ds.value("version", "")},
            {"seed", ds.value("seed", Json())},
            {"recipe_sha256", ds.value("recipe", Json::object()).value("sha256", "")},
            {"code_version", ds.value("code_version", "")},
            {"jobs_sha256", ds.value("jobs", Json::object()).value("keys_sha256", "")},
            {"shard_index", ds.value("shard", Json::object()).value("index", 0)},
            {"shard_count", ds.value("shard", Json::object()).value("count", 1)}};
  if (ds.contains("sources")) have["sources_sha256"] = SourcesSha(SourceSums(ds, where));
  return have;
}

// A published reference (dataset.json + SHA256SUMS committed under datasets/) of this
// very release: its digest, which the build must reproduce.
std::string PublishedDigest(const fs::path& dir, const ReleaseMeta& meta) {
  if (!DirHasOnly(dir, {"dataset.json", "SHA256SUMS", "README.md", kLockFile}))
    throw Error(dir.string() + ": has SHA256SUMS but is neither a release nor a published reference");
  const Json ds = Json::parse(ReadFile(dir / "dataset.json"));
  if (ds.value("name", "") != meta.name || ds.value("version", "") != meta.version) {
    throw Error(dir.string() + ": holds the published reference of " + ds.value("name", "") + " " +
                ds.value("version", "") + ", not of " + meta.name + " " + meta.version);
  }
  return ds.value("digest", "");
}

// An entry's own checks: safe id, split and file paths, none given twice, none both a
// file and a folder ("a" and "a/b"), entry.json reserved.
void CheckEntryNames(const Entry& entry, const std::string& where) {
  CheckSafeName(entry.id, "entry id");
  CheckSafeName(entry.split, where + ": split");
  std::set<std::string> paths;
  for (const auto& f : entry.files) {
    CheckSafeRelPath(f.path, where + ": file");
    if (f.path == kEntryJson) throw Error(where + ": file name 'entry.json' is reserved");
    if (!paths.insert(f.path).second) throw Error(where + ": file '" + f.path + "' given twice");
  }
  for (const auto& p : paths) {
    auto it = paths.lower_bound(p + "/");
    if (it != paths.end() && it->rfind(p + "/", 0) == 0)
      throw Error(where + ": '" + p + "' is both a file and a folder");
  }
}

// Writes the entry's files and entry.json into `staging` (which must not exist) and
// makes them durable.
void StageEntry(const Entry& entry, const fs::path& staging) {
  Release::EntryInfo info;
  info.id = entry.id;
  info.key = entry.key;
  info.split = entry.split;
  info.failed = entry.failed;
  info.failure = entry.failure;
  info.record = entry.record.is_null() ? Json::object() : entry.record;
  fs::create_directories(staging);
  std::set<fs::path> dirs{staging};
  for (const auto& f : entry.files) {
    const fs::path p = staging / f.path;
    if (p.parent_path() != staging && !dirs.count(p.parent_path())) {
      fs::create_directories(p.parent_path());
      for (fs::path q = p.parent_path(); q != staging; q = q.parent_path()) dirs.insert(q);
    }
    WriteFileNew(p, f.bytes);
    info.files.push_back({f.path, Sha256Hex(f.bytes), f.bytes.size()});
  }
  std::sort(info.files.begin(), info.files.end(), [](auto& a, auto& b) { return a.path < b.path; });
  info.entry_digest = EntryDigest(info.id, info.key, info.split, info.failed, info.failure, info.record, info.files);
  WriteFileNew(staging / kEntryJson, EntryJson(info).dump(1) + "\n");
  // One syncfs() per entry makes its files and folders durable before the rename (a
  // per-file fsync costs ~15 ms each: seconds for a 300-frame sweep).
  const UniqueFd fd(::open(staging.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (fd.valid()) ::syncfs(fd.get());
}

}  // namespace

std::unique_ptr<ReleaseWriter> ReleaseWriter::OpenLocked(std::unique_ptr<Impl>& impl, const ReleaseMeta& meta,
                                                         bool resume) {
  const fs::path dir = impl->dir;
  const auto& keys = meta.shard_keys.empty() ? meta.job_keys : meta.shard_keys;
  impl->expected.insert(keys.begin(), keys.end());

  const Json identity = IdentityJson(meta);
  const fs::path meta_path = impl->build_dir() / "meta.json";

  Json build_meta;
  if (fs::exists(meta_path)) {
    // An unfinished build: resume only the very same one.
    build_meta = Json::parse(ReadFile(meta_path));
    const std::string diff = IdentityDiff(identity, build_meta.value("identity", Json::object()),
                                          dir.string() +
                                              " holds an unfinished build of different inputs; "
                                              "delete the folder or build with the same recipe and code:");
    if (!diff.empty()) throw Error(diff);
    impl->published_digest = build_meta.value("published_digest", std::string());
  } else {
    const bool has_sums = fs::exists(dir / "SHA256SUMS");
    const bool has_data = fs::exists(dir / "catalog.sqlite") || fs::exists(dir / "entries");
    if (has_sums && has_data) {
      // A finished release: same inputs = nothing to do; else the version must change.
      Json ds;
      try {
        ds = Json::parse(ReadFile(dir / "dataset.json"));
      } catch (const std::exception& e) {
        throw Error((dir / "dataset.json").string() + ": unreadable finished release: " + e.what());
      }
      const std::string diff = IdentityDiff(
          identity, FinishedIdentity(ds, (dir / "dataset.json").string()),
          dir.string() + " already holds a finished release " + ds.value("name", "") + " " + ds.value("version", "") +
              " made from different inputs. A release version never changes content: bump the "
              "version in the recipe (TFDS: PATCH same records, MINOR added fields, MAJOR "
              "records/splits changed) or write elsewhere with -o. To check that this code "
              "reproduces it, use `drape verify --rebuild`. Differences:");
      if (!diff.empty()) throw Error(diff);
      // Same inputs: nothing to build. Leave the release (and its build.json) untouched.
      impl->already_finished = true;
      impl->LoadDone();
      return std::unique_ptr<ReleaseWriter>(new ReleaseWriter(std::move(impl)));
    } else if (has_sums) {
      impl->published_digest = PublishedDigest(dir, meta);
    } else if (!DirHasOnly(dir, {kLockFile})) {
      throw Error(dir.string() + ": folder is not empty and is not a drape release; refusing to write into it");
    } else if (resume) {
      throw Error(dir.string() + ": nothing to resume (no build has started here)");
    }
    build_meta = Json{{"identity", identity},
                      {"started", NowUtc()},
                      {"started_seconds", NowSeconds()},
                      {"published_digest", impl->published_digest}};
    fs::create_directories(impl->build_dir());
    WriteFileAtomic(meta_path, build_meta.dump(2) + "\n");
  }
  impl->started_utc = build_meta.value("started", NowUtc());
  impl->started_seconds = build_meta.value("started_seconds", NowSeconds());

  // Leftover staging folders are half-written entries: never done.
  fs::remove_all(impl->build_dir() / "staging");
  fs::create_directories(impl->build_dir() / "staging");
  fs::create_directories(dir / "entries");
  impl->LoadDone();
  impl->OpenJournal();
  return std::unique_ptr<ReleaseWriter>(new ReleaseWriter(std::move(impl)));
}

std::set<std::string> ReleaseWriter::DoneKeys() const {
  std::lock_guard<std::mutex> g(impl_->mu);
  return impl_->done;
}

void ReleaseWriter::Commit(const Entry& entry) {
  Impl& m = *impl_;
  const std::string where = "entry '" + entry.id + "' (job '" + entry.key + "')";
  CheckEntryNames(entry, where);
  {
    std::lock_guard<std::mutex> g(m.mu);
    if (!m.expected.count(entry.key)) throw Error(where + ": job key is not one of this build's jobs");
    if (m.already_finished) throw Error(where + ": the release is already finished");
    if (m.done.count(entry.key) || m.in_progress.count(entry.key)) throw Error(where + ": job already committed");
    if (m.ids.count(entry.id)) throw Error(where + ": id already used by another job");
    m.in_progress.insert(entry.key);
    m.ids.insert(entry.id);
  }
  const fs::path staging =
      m.build_dir() / "staging" / (entry.id + "." + std::to_string(::getpid()) + "." + std::to_string(m.staging_seq++));
  const fs::path final_dir = m.dir / "entries" / entry.id;
  try {
    StageEntry(entry, staging);
    // The rename is the commit point: entries/<id> is complete or absent.
    if (::rename(staging.c_str(), final_dir.c_str()) != 0) {
      throw Error(final_dir.string() + ": cannot move entry into place: " + std::strerror(errno));
    }
    FsyncPath(m.dir / "entries");
  } catch (...) {
    std::error_code ec;
    fs::remove_all(staging, ec);
    std::lock_guard<std::mutex> g(m.mu);
    m.in_progress.erase(entry.key);
    m.ids.erase(entry.id);
    throw;
  }
  std::lock_guard<std::mutex> g(m.mu);
  m.in_progress.erase(entry.key);
  m.done.insert(entry.key);
  m.id_of_key[entry.key] = entry.id;
  // One write() per line on an O_APPEND descriptor: lines never interleave.
  const std::string line =
      Json{{"id", entry.id}, {"key", entry.key}, {"timing", entry.timing.is_null() ? Json::object() : entry.timing}}
          .dump() +
      "\n";
  WriteAll(m.journal_fd, line, (m.build_dir() / "journal.jsonl").string());
}

namespace {

// A finished release reported as it is.
ReleaseWriter::Summary FinishedSummary(const fs::path& dir) {
  const Release r = Release::Open(dir);
  ReleaseWriter::Summary s;
  s.digest = r.digest();
  s.entries = static_cast<int>(r.entries().size());
  for (const auto& e : r.entries()) {
    s.failed += e.failed;
    for (const auto& f : e.files) s.bytes += f.size;
  }
  s.counts = r.dataset().value("counts", Json::object());
  s.wall_seconds = r.build_info().value("wall_seconds", 0.0);
  return s;
}

void CheckAllCommitted(const fs::path& dir, const std::vector<std::string>& keys, const std::set<std::string>& done,
                       const std::set<std::string>& in_progress) {
  std::vector<std::string> missing;
  for (const auto& k : keys) {
    if (!done.count(k)) missing.push_back(k);
  }
  if (missing.empty() && in_progress.empty()) return;
  std::string msg = dir.string() + ": cannot finalize: " + std::to_string(missing.size()) + " of " +
                    std::to_string(keys.size()) + " jobs not committed";
  for (size_t i = 0; i < missing.size() && i < 5; ++i) msg += (i ? ", " : " (") + missing[i];
  if (!missing.empty()) msg += missing.size() > 5 ? ", …)" : ")";
  throw Error(msg);
}

// dataset.json: the recipe, its jobs and sources, counts and the digest.
Json DatasetJson(const ReleaseMeta& meta, const ReleaseWriter::Summary& s) {
  Json dataset{{"name", meta.name},
               {"version", meta.version},
               {"description", meta.description},
               {"license", meta.license},
               {"seed", meta.seed},
               {"code_version", meta.code_version},
               {"recipe", {{"sha256", meta.recipe_sha256}, {"text", meta.recipe_text}}},
               {"summary", meta.recipe_summary},
               {"jobs", {{"count", meta.job_keys.size()}, {"keys_sha256", JobKeysSha(meta.job_keys)}}}};
  if (meta.shard_count > 1) {
    dataset["shard"] = {{"index", meta.shard_index},
                        {"count", meta.shard_count},
                        {"jobs", meta.shard_keys.empty() ? meta.job_keys.size() : meta.shard_keys.size()}};
  }
  if (!meta.sources.empty()) {
    Json src = Json::object();
    for (const auto& f : meta.sources) src[f.recipe_path] = {{"path", f.release_path}, {"sha256", f.sha256}};
    dataset["sources"] = src;
  }
  dataset["format_version"] = kFormatVersion;
  dataset["counts"] = s.counts;
  dataset["catalog"] = {{"file", "catalog.sqlite"}, {"blobs", meta.catalog_blobs}};
  dataset["digest"] = s.digest;
  dataset["digest_algorithm"] = kDigestAlgorithm;
  return dataset;
}

// The recipe's imported files, as hashed when the build started, copied into the release.
void CopySources(const std::vector<SourceFile>& sources, const fs::path& dir) {
  for (const auto& f : sources) {
    const std::string bytes = drape::ReadFile(f.file);
    if (Sha256Hex(bytes) != f.sha256)
      throw Error(f.file.string() + ": changed while the release was being built (sha256 " + Sha256Hex(bytes) +
                  ", was " + f.sha256 + "); build again");
    WriteFileAtomic(dir / f.release_path, bytes);
  }
}

// catalog.sqlite (written beside, then renamed into place), README.md, index.html and the
// 3D viewer's files; returns the viewer files (outside entries/, so in SHA256SUMS but
// not in the digest).
std::vector<std::string> WriteCatalogAndGallery(const fs::path& dir, const fs::path& build_dir, const ReleaseMeta& meta,
                                                const Json& dataset, const std::vector<Release::EntryInfo>& entries) {
  const fs::path cat_tmp = build_dir / "catalog.sqlite.tmp";
  fs::remove(cat_tmp);
  WriteCatalog(cat_tmp, dir, dataset, entries, meta.job_keys, meta.catalog_blobs);
  FsyncPath(cat_tmp);
  fs::rename(cat_tmp, dir / "catalog.sqlite");

  WriteFileAtomic(dir / "README.md", DatasetCard(dataset, entries));
  WriteFileAtomic(dir / "index.html", Gallery(dataset, entries));
  std::vector<std::string> viewer_files;
  for (const auto& [path, bytes] : GalleryViewerFiles(dir, entries)) {
    fs::create_directories((dir / path).parent_path());
    WriteFileAtomic(dir / path, bytes);
    viewer_files.push_back(path);
  }
  return viewer_files;
}

// SHA256SUMS's lines: every entry file, the top-level files, the copied sources; adds
// their sizes to *bytes.
std::map<std::string, std::string> ReleaseSums(const fs::path& dir, const std::vector<Release::EntryInfo>& entries,
                                               const std::vector<std::string>& top_files,
                                               const std::vector<SourceFile>& sources, uint64_t* bytes) {
  std::map<std::string, std::string> sums;
  for (const auto& e : entries) {
    const std::string base = "entries/" + e.id + "/";
    for (const auto& f : e.files) {
      sums[base + f.path] = f.sha256;
      *bytes += f.size;
    }
    sums[base + kEntryJson] = Sha256File(dir / "entries" / e.id / kEntryJson);
    *bytes += fs::file_size(dir / "entries" / e.id / kEntryJson);
  }
  for (const auto& f : top_files) {
    sums[f] = Sha256File(dir / f);
    *bytes += fs::file_size(dir / f);
  }
  for (const auto& f : sources) {
    sums[f.release_path] = f.sha256;
    *bytes += fs::file_size(dir / f.release_path);
  }
  return sums;
}

}  // namespace

ReleaseWriter::Summary ReleaseWriter::Finalize() {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> g(m.mu);
  if (m.lock_fd < 0) throw Error(m.dir.string() + ": release already finalized");
  if (m.already_finished) {
    // Report the finished release as it is; rewrite nothing.
    Summary s = FinishedSummary(m.dir);
    m.DropLock();
    return s;
  }
  CheckAllCommitted(m.dir, m.meta.shard_keys.empty() ? m.meta.job_keys : m.meta.shard_keys, m.done, m.in_progress);

  // Everything below is rebuilt from the entry folders: the same for any history.
  std::vector<Release::EntryInfo> entries = ScanEntries(m.dir);
  for (auto& e : entries) {
    e.entry_digest = EntryDigest(e.id, e.key, e.split, e.failed, e.failure, e.record, e.files);
  }
  Summary s;
  s.digest = ComputeDigest(entries, SourceSums(m.meta.sources));
  s.entries = static_cast<int>(entries.size());
  for (const auto& e : entries) s.failed += e.failed;
  s.counts = Counts(entries);
  s.published_digest = m.published_digest;
  s.matches_published = m.published_digest.empty() || m.published_digest == s.digest;

  const ReleaseMeta& meta = m.meta;
  const Json dataset = DatasetJson(meta, s);
  CopySources(meta.sources, m.dir);
  std::vector<std::string> top_files = WriteCatalogAndGallery(m.dir, m.build_dir(), meta, dataset, entries);

  // build.json: timings only; not in SHA256SUMS.
  const double now = NowSeconds();
  s.wall_seconds = now - m.started_seconds;
  Json timings = Json::object();
  for (auto& [id, t] : m.ReadJournalTimings()) timings[id] = t;
  Json build{{"started", m.started_utc},
             {"finished", NowUtc()},
             {"wall_seconds", s.wall_seconds},
             {"host", HostName()},
             {"code_version", meta.code_version}};
  for (auto it = m.build_info.begin(); it != m.build_info.end(); ++it) build[it.key()] = it.value();
  build["entry_timing"] = timings;
  WriteFileAtomic(m.dir / "build.json", build.dump(1) + "\n");
  WriteFileAtomic(m.dir / "dataset.json", dataset.dump(2) + "\n");

  for (const char* f : {"catalog.sqlite", "README.md", "index.html", "dataset.json"}) top_files.push_back(f);
  // SHA256SUMS last: its presence marks a finished release.
  WriteFileAtomic(m.dir / "SHA256SUMS", FormatSums(ReleaseSums(m.dir, entries, top_files, meta.sources, &s.bytes)));
  FsyncPath(m.dir);
  if (m.journal_fd >= 0) ::close(m.journal_fd);
  m.journal_fd = -1;
  fs::remove_all(m.build_dir());
  m.DropLock();
  return s;
}

// ---------------------------------------------------------------- reader

Release Release::Open(const fs::path& dir) {
  if (!fs::exists(dir / "dataset.json") || !fs::exists(dir / "SHA256SUMS") || !fs::exists(dir / "catalog.sqlite")) {
    if (fs::exists(dir / kBuildDir))
      throw Error(dir.string() + ": unfinished build (resume it with drape build --resume)");
    throw Error(dir.string() + ": not a finished drape release (needs dataset.json, catalog.sqlite, SHA256SUMS)");
  }
  Release r;
  r.dir_ = dir;
  const std::string where = (dir / "dataset.json").string();
  try {
    r.dataset_ = Json::parse(drape::ReadFile(dir / "dataset.json"));
  } catch (const Json::exception& e) {
    throw Error(where + ": " + e.what());
  }
  CheckFormatVersion(r.dataset_, where);
  ReadCatalog(dir / "catalog.sqlite", &r.entries_, &r.job_keys_);
  std::map<std::string, std::string> id_of_key;
  for (size_t i = 0; i < r.entries_.size(); ++i) {
    const auto& e = r.entries_[i];
    if (i > 0 && r.entries_[i - 1].id == e.id)
      throw Error((dir / "catalog.sqlite").string() + ": entry '" + e.id + "' is listed twice");
    auto [it, fresh] = id_of_key.emplace(e.key, e.id);
    if (!fresh)
      throw Error((dir / "catalog.sqlite").string() + ": job '" + e.key + "' is listed twice (entries '" + it->second +
                  "' and '" + e.id + "')");
    CheckSafeName(e.id, (dir / "catalog.sqlite").string() + ": entry id");
    if (!fs::is_directory(dir / "entries" / e.id))
      throw Error((dir / "entries" / e.id).string() +
                  ": entry folder missing (catalog.sqlite lists it; "
                  "run drape verify " +
                  dir.string() + ")");
  }
  SourceSums(r.dataset_, where);                                     // checks the shape
  const Json sources = r.dataset_.value("sources", Json::object());  // items() must not outlive it
  for (const auto& [written, v] : sources.items()) r.sources_[written] = dir / v["path"].get<std::string>();
  return r;
}

const Release::EntryInfo* Release::Find(const std::string& id) const {
  auto it = std::lower_bound(entries_.begin(), entries_.end(), id,
                             [](const EntryInfo& e, const std::string& v) { return e.id < v; });
  return it != entries_.end() && it->id == id ? &*it : nullptr;
}

fs::path Release::EntryPath(const std::string& id, const std::string& path) const {
  CheckSafeName(id, "entry id");
  if (path.empty()) return dir_ / "entries" / id;
  CheckSafeRelPath(path, "entry file");
  return dir_ / "entries" / id / path;
}

std::string Release::ReadFile(const std::string& id, const std::string& path) const {
  if (!Find(id)) throw Error(dir_.string() + ": no entry '" + id + "'");
  return drape::ReadFile(EntryPath(id, path));
}

std::string Release::digest() const { return dataset_.value("digest", std::string()); }

Json Release::build_info() const {
  const fs::path p = dir_ / "build.json";
  if (!fs::exists(p)) return Json::object();
  try {
    return Json::parse(drape::ReadFile(p));
  } catch (const std::exception&) {
    return Json::object();
  }
}

// ---------------------------------------------------------------- rebuild hook

namespace {
Rebuilder& RebuilderSlot() {
  static Rebuilder fn;
  return fn;
}
}  // namespace
void SetRebuilder(Rebuilder fn) { RebuilderSlot() = std::move(fn); }
const Rebuilder& GetRebuilder() { return RebuilderSlot(); }

}  // namespace drape
