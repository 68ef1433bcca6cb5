// drape info / ls / verify / merge: looking at, checking and assembling releases.
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <map>
#include <sstream>

#include "cli/args.h"
#include "cli/command.h"
#include "common/error.h"
#include "generator/release/release.h"

namespace fs = std::filesystem;

namespace drape::cli {
namespace {

std::string Bytes(uint64_t b) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  double v = static_cast<double>(b);
  int u = 0;
  while (v >= 1000 && u < 4) {
    v /= 1000;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof(buf), u ? "%.1f %s" : "%.0f %s", v, units[u]);
  return buf;
}

std::string Str(const Json& r, const char* k) {
  return r.is_object() && r.contains(k) && r[k].is_string() ? r[k].get<std::string>() : std::string();
}
std::string CategoryOf(const Release::EntryInfo& e) {
  const std::string c = Str(e.record, "category");
  return c.empty() ? "unknown" : c;
}
std::string AnchorOf(const Release::EntryInfo& e) {
  if (e.record.is_object() && e.record.contains("anchor")) {
    const Json& a = e.record["anchor"];
    if (a.is_string()) return a.get<std::string>();
    if (a.is_object()) return Str(a, "label");
  }
  return "";
}
bool FusionErrorOf(const Release::EntryInfo& e, double* v) {
  if (!e.record.is_object() || !e.record.contains("fusion") || !e.record["fusion"].is_object()) return false;
  const Json& f = e.record["fusion"];
  if (f.contains("recon_to_truth_mean") && f["recon_to_truth_mean"].is_number()) {
    *v = f["recon_to_truth_mean"].get<double>();
    return true;
  }
  return false;
}

// Counts in first-seen order of sorted keys (std::map) as JSON.
Json CountsJson(const std::map<std::string, int>& m) {
  Json j = Json::object();
  for (const auto& [k, n] : m) j[k] = n;
  return j;
}

std::string CountsLine(const Json& j) {
  std::string s;
  for (auto it = j.begin(); it != j.end(); ++it) s += (s.empty() ? "" : ", ") + it.key() + " " + it.value().dump();
  return s.empty() ? "-" : s;
}

// drape info's facts: counts by split, category and anchor, failures, bytes by file kind,
// build and recipe.
Json InfoJson(const Release& r) {
  const Json& ds = r.dataset();
  std::map<std::string, int> splits, cats, anchors;
  std::map<std::string, uint64_t> sizes;  // by file kind
  Json failures = Json::array();
  uint64_t total = 0;
  for (const auto& e : r.entries()) {
    ++splits[e.split];
    ++cats[CategoryOf(e)];
    const std::string a = AnchorOf(e);
    if (!a.empty()) ++anchors[a];
    if (e.failed) failures.push_back({{"id", e.id}, {"key", e.key}, {"failure", e.failure}});
    for (const auto& f : e.files) {
      const auto slash = f.path.find('/');
      sizes[slash == std::string::npos ? f.path : f.path.substr(0, slash + 1)] += f.size;
      total += f.size;
    }
    std::error_code ec;
    const auto ej = fs::file_size(r.EntryPath(e.id, "entry.json"), ec);
    if (!ec) {
      sizes["entry.json"] += ej;
      total += ej;
    }
  }
  for (const char* f : {"catalog.sqlite", "dataset.json", "README.md", "index.html", "SHA256SUMS", "build.json"}) {
    std::error_code ec;
    const auto s = fs::file_size(r.dir() / f, ec);
    if (!ec) {
      sizes[f] += s;
      total += s;
    }
  }
  const Json build = r.build_info();
  Json out{{"name", ds.value("name", "")},
           {"version", ds.value("version", "")},
           {"path", r.dir().string()},
           {"digest", r.digest()},
           {"entries", r.entries().size()},
           {"failed", failures.size()},
           {"splits", Json::object()},
           {"categories", CountsJson(cats)},
           {"anchors", CountsJson(anchors)},
           {"failures", failures},
           {"bytes", total},
           {"bytes_by_file", Json::object()},
           {"build_seconds", build.value("wall_seconds", Json())},
           {"build_started", build.value("started", Json())},
           {"build_host", build.value("host", Json())},
           {"seed", ds.value("seed", Json())},
           {"recipe_sha256", ds.value("recipe", Json::object()).value("sha256", "")},
           {"code_version", ds.value("code_version", "")}};
  for (const auto& [k, s] : sizes) out["bytes_by_file"][k] = s;
  // Splits in their usual order (train, calibration, test), then any others.
  for (const char* s : {"train", "calibration", "test"})
    if (splits.count(s)) out["splits"][s] = splits[s];
  for (const auto& [k, n] : splits)
    if (!out["splits"].contains(k)) out["splits"][k] = n;
  if (ds.contains("shard")) out["shard"] = ds["shard"];
  return out;
}

void PrintInfo(const Release& r, const Json& out) {
  const Json& ds = r.dataset();
  const Json build = r.build_info();
  std::cout << out["name"].get<std::string>() << " " << out["version"].get<std::string>() << "  (" << r.dir().string()
            << ")\n";
  std::cout << "digest       " << r.digest() << "\n";
  std::cout << "entries      " << r.entries().size() << " (" << out["failures"].size() << " failed)\n";
  std::cout << "splits       " << CountsLine(out["splits"]) << "\n";
  std::cout << "categories   " << CountsLine(out["categories"]) << "\n";
  std::cout << "anchors      " << CountsLine(out["anchors"]) << "\n";
  std::cout << "size         " << Bytes(out["bytes"].get<uint64_t>());
  std::string by;
  for (const auto& [k, s] : out["bytes_by_file"].items())
    by += (by.empty() ? "" : ", ") + k + " " + Bytes(s.get<uint64_t>());
  std::cout << " (" << by << ")\n";
  if (build.contains("wall_seconds")) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.1f s", build["wall_seconds"].get<double>());
    std::cout << "build time   " << buf << " (started " << build.value("started", "?") << " on "
              << build.value("host", "?") << ")\n";
  }
  std::cout << "seed         " << ds.value("seed", Json()).dump() << "\n";
  std::cout << "recipe       sha256 " << out["recipe_sha256"].get<std::string>() << "\n";
  std::cout << "code         " << out["code_version"].get<std::string>() << "\n";
  if (ds.contains("shard")) std::cout << "shard        " << ds["shard"].dump() << "\n";
  for (const auto& f : out["failures"])
    std::cout << "failed       " << f["id"].get<std::string>() << ": " << f["failure"].get<std::string>() << "\n";
}

int RunInfo(const std::vector<std::string>& argv) {
  Args args(argv, {"--json"}, {});
  if (args.help()) {
    std::cout << "usage: drape info RELEASE [--json]\n";
    return 0;
  }
  args.RequirePositional(1, 1, "RELEASE");
  const Release r = Release::Open(args.positional()[0]);
  const Json out = InfoJson(r);
  if (args.Flag("--json")) {
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  PrintInfo(r, out);
  return 0;
}

int RunLs(const std::vector<std::string>& argv) {
  Args args(argv, {"--json", "--failed"}, {"--split", "--category", "--anchor"});
  if (args.help()) {
    std::cout << "usage: drape ls RELEASE [--split S] [--category C] [--anchor A] [--failed] [--json]\n"
                 "Lists the entries of a release, optionally filtered (anchor = anchor label).\n";
    return 0;
  }
  args.RequirePositional(1, 1, "RELEASE");
  const Release r = Release::Open(args.positional()[0]);
  const auto split = args.Get("--split"), cat = args.Get("--category"), anchor = args.Get("--anchor");
  std::vector<const Release::EntryInfo*> rows;
  for (const auto& e : r.entries()) {
    if (split && e.split != *split) continue;
    if (cat && CategoryOf(e) != *cat) continue;
    if (anchor && AnchorOf(e) != *anchor) continue;
    if (args.Flag("--failed") && !e.failed) continue;
    rows.push_back(&e);
  }
  if (args.Flag("--json")) {
    Json out = Json::array();
    for (const auto* e : rows) {
      Json files = Json::array();
      for (const auto& f : e->files) files.push_back({{"path", f.path}, {"sha256", f.sha256}, {"size", f.size}});
      out.push_back({{"id", e->id},
                     {"key", e->key},
                     {"split", e->split},
                     {"failed", e->failed},
                     {"failure", e->failure},
                     {"record", e->record},
                     {"files", files},
                     {"path", r.EntryPath(e->id).string()}});
    }
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  std::vector<std::vector<std::string>> table = {
      {"ID", "SPLIT", "CATEGORY", "INSTANCE", "MATERIAL", "ANCHOR", "FUSION_ERR", "STATUS"}};
  for (const auto* e : rows) {
    double err = 0;
    char buf[32] = "-";
    if (FusionErrorOf(*e, &err)) std::snprintf(buf, sizeof(buf), "%.2fmm", err * 1000);
    table.push_back({e->id, e->split, CategoryOf(*e), Str(e->record, "instance"), Str(e->record, "material"),
                     AnchorOf(*e), buf, e->failed ? "failed: " + e->failure : "ok"});
  }
  std::vector<size_t> w(table[0].size(), 0);
  for (const auto& row : table)
    for (size_t c = 0; c < row.size(); ++c) w[c] = std::max(w[c], row[c].size());
  for (const auto& row : table) {
    std::string line;
    for (size_t c = 0; c < row.size(); ++c) {
      line += row[c];
      if (c + 1 < row.size()) line += std::string(w[c] - row[c].size() + 2, ' ');
    }
    std::cout << line << "\n";
  }
  std::cerr << rows.size() << " of " << r.entries().size() << " entries\n";
  return 0;
}

void PrintReport(const VerifyReport& rep) {
  for (const auto& p : rep.missing) std::cout << "missing: " << p << "\n";
  for (const auto& p : rep.extra) std::cout << "extra:   " << p << "\n";
  for (const auto& p : rep.changed) std::cout << "changed: " << p << "\n";
  for (const auto& p : rep.problems) std::cout << "error:   " << p << "\n";
}

int RunVerify(const std::vector<std::string>& argv) {
  Args args(argv, {"--rebuild", "--keep", "--json"}, {"--published", "-j", "--recipe"});
  if (args.help()) {
    std::cout << "usage: drape verify RELEASE [--published REF_DIR] [--rebuild [-j N] [--recipe FILE] [--keep]]\n"
                 "Checks every file against SHA256SUMS, looks for unlisted files, and recomputes the\n"
                 "release digest from the entries; names each missing, extra or changed file.\n"
                 "  --published REF_DIR  also compare with a published reference (the dataset.json and\n"
                 "                       SHA256SUMS committed under datasets/NAME/VERSION/): digest and\n"
                 "                       content files (entries/, catalog.sqlite)\n"
                 "  --rebuild            rebuild the recipe into a temporary folder and compare entry by\n"
                 "                       entry (-j threads; --recipe if the recipe refers to files; --keep\n"
                 "                       keeps the rebuilt folder)\n"
                 "Exit status 0 if everything matches, 1 otherwise.\n";
    return 0;
  }
  args.RequirePositional(1, 1, "RELEASE");
  const fs::path dir = args.positional()[0];
  const VerifyReport rep = Verify(dir);
  bool ok = rep.ok();
  PrintReport(rep);
  if (rep.ok()) std::cout << "ok: " << rep.files_checked << " files, digest " << rep.actual_digest << "\n";
  if (const auto ref = args.Get("--published")) {
    const VerifyReport pub = CompareToPublished(dir, *ref);
    for (const auto& p : pub.missing) std::cout << "published has, release lacks: " << p << "\n";
    for (const auto& p : pub.extra) std::cout << "release has, published lacks: " << p << "\n";
    for (const auto& p : pub.changed) std::cout << "differs from published: " << p << "\n";
    for (const auto& p : pub.problems) std::cout << "error:   " << p << "\n";
    if (pub.ok()) std::cout << "ok: matches the published reference " << *ref << "\n";
    ok = ok && pub.ok();
  }
  if (args.Flag("--rebuild")) {
    const Rebuilder& rebuild = GetRebuilder();
    if (!rebuild) throw Error("--rebuild: this drape binary has no rebuilder registered (needs the build library)");
    const Release original = Release::Open(dir);
    RebuildRequest req;
    req.release = dir;
    req.recipe_path = args.Get("--recipe", "");
    req.threads = static_cast<int>(args.GetInt("-j").value_or(0));
    req.out = fs::temp_directory_path() / ("drape-rebuild-" + original.dataset().value("name", "x") + "-" +
                                           original.dataset().value("version", "x") + "-" + std::to_string(::getpid()));
    fs::remove_all(req.out);
    std::cout << "rebuilding into " << req.out.string() << "\n";
    rebuild(req);
    const Release again = Release::Open(req.out);
    const ReleaseDiff d = CompareReleases(original, again);
    for (const auto& id : d.only_in_a) std::cout << "not rebuilt: " << id << "\n";
    for (const auto& id : d.only_in_b) std::cout << "only in rebuild: " << id << "\n";
    for (const auto& s : d.differ) std::cout << "rebuilt differently: " << s << "\n";
    if (d.same() && again.digest() == original.digest()) {
      std::cout << "ok: rebuild reproduces all " << original.entries().size() << " entries, digest " << again.digest()
                << "\n";
    } else {
      std::cout << "error:   rebuild digest " << again.digest() << " vs release " << original.digest() << "\n";
      ok = false;
    }
    if (args.Flag("--keep"))
      std::cout << "kept " << req.out.string() << "\n";
    else
      fs::remove_all(req.out);
  }
  return ok ? 0 : 1;
}

int RunMerge(const std::vector<std::string>& argv) {
  Args args(argv, {}, {"-o", "--output"});
  if (args.help()) {
    std::cout << "usage: drape merge SHARD_DIR... -o RELEASE\n"
                 "Merges the finished shards of `drape build --shard K/N` into one release. Checks\n"
                 "that they come from the same recipe and code and cover every job exactly once.\n";
    return 0;
  }
  args.RequirePositional(1, 100000, "SHARD_DIR...");
  const auto out = args.Get("-o") ? args.Get("-o") : args.Get("--output");
  if (!out) throw Error("merge: -o RELEASE is required");
  std::vector<fs::path> shards(args.positional().begin(), args.positional().end());
  const ReleaseWriter::Summary s = Merge(shards, *out);
  std::cout << "merged " << shards.size() << " shards into " << *out << ": " << s.entries << " entries (" << s.failed
            << " failed), " << Bytes(s.bytes) << ", digest " << s.digest << "\n";
  return 0;
}

Register info_reg({"info", "summary of a release: counts, failures, sizes, build time", "drape info RELEASE [--json]",
                   RunInfo});
Register ls_reg({"ls", "list a release's entries (filter by split, category, anchor)",
                 "drape ls RELEASE [--split S] [--category C] [--anchor A] [--json]", RunLs});
Register verify_reg({"verify", "check a release's files and digest (and optionally rebuild it)",
                     "drape verify RELEASE [--published REF] [--rebuild]", RunVerify});
Register merge_reg({"merge", "merge shard builds into one release", "drape merge SHARD_DIR... -o RELEASE", RunMerge});

}  // namespace
}  // namespace drape::cli
