// drape info / ls / verify / merge: looking at, checking and assembling releases.
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "cli/command.h"
#include "cli/options.h"
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

// The command lines of info, ls, verify and merge.
struct ReleaseArgs {
  std::string release;  // info, ls, verify
  bool json = false;
  std::string split, category, anchor;  // ls filters
  bool failed = false;
  std::string published, recipe;  // verify
  bool rebuild = false, keep = false;
  int jobs = 0;
  std::vector<std::string> shards;  // merge
  std::string output;
};

int RunInfo(const ReleaseArgs& args) {
  const Release r = Release::Open(args.release);
  const Json out = InfoJson(r);
  if (args.json) {
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  PrintInfo(r, out);
  return 0;
}

int RunLs(const ReleaseArgs& args) {
  const Release r = Release::Open(args.release);
  std::vector<const Release::EntryInfo*> rows;
  for (const auto& e : r.entries()) {
    if (!args.split.empty() && e.split != args.split) continue;
    if (!args.category.empty() && CategoryOf(e) != args.category) continue;
    if (!args.anchor.empty() && AnchorOf(e) != args.anchor) continue;
    if (args.failed && !e.failed) continue;
    rows.push_back(&e);
  }
  if (args.json) {
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

int RunVerify(const ReleaseArgs& args) {
  const fs::path dir = args.release;
  const VerifyReport rep = Verify(dir);
  bool ok = rep.ok();
  PrintReport(rep);
  if (rep.ok()) std::cout << "ok: " << rep.files_checked << " files, digest " << rep.actual_digest << "\n";
  if (!args.published.empty()) {
    const VerifyReport pub = CompareToPublished(dir, args.published);
    for (const auto& p : pub.missing) std::cout << "published has, release lacks: " << p << "\n";
    for (const auto& p : pub.extra) std::cout << "release has, published lacks: " << p << "\n";
    for (const auto& p : pub.changed) std::cout << "differs from published: " << p << "\n";
    for (const auto& p : pub.problems) std::cout << "error:   " << p << "\n";
    if (pub.ok()) std::cout << "ok: matches the published reference " << args.published << "\n";
    ok = ok && pub.ok();
  }
  if (args.rebuild) {
    const Rebuilder& rebuild = GetRebuilder();
    if (!rebuild) throw Error("--rebuild: this drape binary has no rebuilder registered (needs the build library)");
    const Release original = Release::Open(dir);
    RebuildRequest req;
    req.release = dir;
    req.recipe_path = args.recipe;
    req.threads = args.jobs;
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
    if (args.keep)
      std::cout << "kept " << req.out.string() << "\n";
    else
      fs::remove_all(req.out);
  }
  return ok ? 0 : 1;
}

int RunMerge(const ReleaseArgs& args) {
  const fs::path out = args.output;
  std::vector<fs::path> shards(args.shards.begin(), args.shards.end());
  const ReleaseWriter::Summary s = Merge(shards, out);
  std::cout << "merged " << shards.size() << " shards into " << out.string() << ": " << s.entries << " entries ("
            << s.failed << " failed), " << Bytes(s.bytes) << ", digest " << s.digest << "\n";
  return 0;
}

Runner SetupInfo(CLI::App& app) {
  auto a = std::make_shared<ReleaseArgs>();
  app.add_option("RELEASE", a->release, "a release folder")->required();
  AddJson(app, a->json);
  return [a] { return RunInfo(*a); };
}

Runner SetupLs(CLI::App& app) {
  auto a = std::make_shared<ReleaseArgs>();
  app.add_option("RELEASE", a->release, "a release folder")->required();
  app.add_option("--split", a->split, "only this split's entries");
  app.add_option("--category", a->category, "only this category's entries");
  app.add_option("--anchor", a->anchor, "only entries hung from this anchor (its label)");
  app.add_flag("--failed", a->failed, "only failed entries");
  AddJson(app, a->json);
  return [a] { return RunLs(*a); };
}

Runner SetupVerify(CLI::App& app) {
  auto a = std::make_shared<ReleaseArgs>();
  app.footer(
      "Checks every file against SHA256SUMS, looks for unlisted files, and recomputes the release digest from\n"
      "the entries; names each missing, extra or changed file. Exit status 0 if everything matches, 1 otherwise.");
  app.add_option("RELEASE", a->release, "a release folder")->required();
  app.add_option("--published", a->published,
                 "also compare with a published reference (the dataset.json and SHA256SUMS committed under "
                 "datasets/NAME/VERSION/): digest and content files (entries/, catalog.sqlite)")
      ->type_name("REF_DIR");
  app.add_flag("--rebuild", a->rebuild, "rebuild the recipe into a temporary folder and compare entry by entry");
  AddJobs(app, a->jobs, "with --rebuild: jobs run at once (default: all cores)");
  app.add_option("--recipe", a->recipe, "with --rebuild: the recipe file, if it refers to files")->type_name("FILE");
  app.add_flag("--keep", a->keep, "with --rebuild: keep the rebuilt folder");
  return [a] {
    if (!a->rebuild && (a->jobs || !a->recipe.empty() || a->keep))
      throw Error("-j/--jobs, --recipe and --keep go with --rebuild");
    return RunVerify(*a);
  };
}

Runner SetupMerge(CLI::App& app) {
  auto a = std::make_shared<ReleaseArgs>();
  app.footer(
      "Merges the finished shards of `drape build --shard K/N` into one release. Checks that they come from the\n"
      "same recipe and code and cover every job exactly once.");
  app.add_option("SHARD_DIR", a->shards, "the shards' release folders")->required();
  AddOutput(app, a->output, "the merged release's folder")->required();
  return [a] { return RunMerge(*a); };
}

Register info_reg({"info", "summary of a release: counts, failures, sizes, build time", SetupInfo});
Register ls_reg({"ls", "list a release's entries (filter by split, category, anchor)", SetupLs});
Register verify_reg({"verify", "check a release's files and digest (and optionally rebuild it)", SetupVerify});
Register merge_reg({"merge", "merge shard builds into one release", SetupMerge});

}  // namespace
}  // namespace drape::cli
