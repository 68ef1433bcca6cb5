// drape build RECIPE [-o DIR] [-j N] [--resume] [--shard K/N] [--keep-going]
#include <csignal>
#include <iostream>
#include <regex>

#include "cli/args.h"
#include "cli/command.h"
#include "common/error.h"
#include "generator/pipeline/build.h"
#include "generator/pipeline/build_mpi.h"
#include "generator/recipe/recipe.h"
#include "generator/release/release.h"

namespace drape::cli {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void OnSigint(int) {
  g_stop.store(true);
  // A second Ctrl-C kills at once (every committed entry is already safe on disk).
  std::signal(SIGINT, SIG_DFL);
}

const char* kUsage = R"(Usage: drape build RECIPE [-o DIR] [-j N] [--resume] [--shard K/N] [--keep-going] [--quiet]

Builds the release a recipe describes (recipes/README.md documents recipes).

  -o DIR          output folder (default datasets/<name>/<version>/)
  -j N            jobs run at once (default: all cores); entries are identical for any N
  --resume        continue an interrupted build in DIR (a plain build resumes one too)
  --shard K/N     build only jobs with index % N == K-1 (merge shards with drape merge)
  --keep-going    turn unexpected per-job errors into failed entries instead of stopping
  --quiet         no progress output

Under mpirun (mpirun -np N drape build RECIPE -o DIR) rank 0 hands out jobs and writes
the release while ranks 1..N-1 simulate, one job each at a time (-j is ignored); same
release digest as a one-process build (docs/cluster.md).

Ctrl-C stops handing out jobs, lets running ones finish and commit, and exits; run the
same command (or add --resume) to continue. Exit status: 0 all entries built, 1 bad
input, 4 the release was built but some entries failed (listed), 5 stopped early
(interrupted, or an unexpected job error without --keep-going).)";

// Exit status of a build that did not throw (see kUsage).
int ExitStatus(const BuildReport& r) {
  if (r.aborted || r.interrupted) return 5;
  return r.release_failed > 0 ? 4 : 0;
}

int Run(const std::vector<std::string>& argv) {
  Args args(argv, {"--resume", "--keep-going", "--quiet"}, {"-o", "-j", "--shard"});
  if (args.help()) {
    std::cout << kUsage << "\n";
    return 0;
  }
  args.RequirePositional(1, 1, "RECIPE");
  const Recipe recipe = LoadRecipe(args.positional()[0]);
  // Under mpirun every rank runs this command; rank 0 speaks for all of them.
  const bool mpi = MpiRequested();
  const bool speaker = !mpi || MpiLaunchRank() == 0;
  if (speaker)
    for (const auto& w : recipe.warnings) std::cerr << "drape build: warning: " << w << "\n";

  BuildOptions o;
  if (auto out = args.Get("-o")) o.output = *out;
  if (auto j = args.GetInt("-j")) {
    if (*j < 1) throw Error("-j: must be >= 1");
    o.threads = static_cast<int>(*j);
  }
  o.resume = args.Flag("--resume");
  o.keep_going = args.Flag("--keep-going");
  if (args.Flag("--quiet")) o.progress = ProgressMode::kQuiet;
  if (auto s = args.Get("--shard")) {
    std::smatch m;
    if (!std::regex_match(*s, m, std::regex("([0-9]+)/([0-9]+)")))
      throw Error("--shard: expected K/N (e.g. 2/8), got '" + *s + "'");
    o.shard_index = std::stoi(m[1]);
    o.shard_count = std::stoi(m[2]);
    if (o.shard_count < 1 || o.shard_index < 1 || o.shard_index > o.shard_count)
      throw Error("--shard " + *s + ": need 1 <= K <= N");
  }
  o.stop = &g_stop;
  g_stop.store(false);
  auto previous = std::signal(SIGINT, OnSigint);
  BuildReport r;
  try {
    if (mpi) {
      // Rank 0 coordinates and rethrows its errors; the other ranks simulate and
      // exit with rank 0's status without printing (see generator/pipeline/build_mpi.h).
      MpiBuildOutcome m = RunBuildMpi(recipe, o);
      if (!m.coordinator) {
        std::signal(SIGINT, previous);
        return m.exit_status >= 0 ? m.exit_status : ExitStatus(m.report);
      }
      r = std::move(m.report);
    } else {
      r = RunBuild(recipe, o);
    }
  } catch (...) {
    std::signal(SIGINT, previous);
    throw;
  }
  std::signal(SIGINT, previous);

  if (!r.failures.empty()) {
    std::cerr << "drape build: " << r.failures.size() << " entr" << (r.failures.size() == 1 ? "y" : "ies")
              << " failed:\n";
    for (const auto& [key, why] : r.failures) std::cerr << "  " << key << ": " << why << "\n";
  }
  std::string again = "drape build " + args.positional()[0] + " -o " + r.output.string() + " --resume";
  if (o.shard_count > 1) again += " --shard " + std::to_string(o.shard_index) + "/" + std::to_string(o.shard_count);
  if (r.aborted) {
    std::cerr << "drape build: stopped: " << r.error << "\n"
              << "  committed entries are kept; fix the cause and run: " << again << "\n"
              << "  (or add --keep-going to record such errors as failed entries)\n";
    return 5;
  }
  if (r.interrupted) {
    std::cerr << "drape build: interrupted after " << r.already_done + r.built << "/" << r.shard_jobs
              << " jobs; continue with: " << again << "\n";
    return 5;
  }
  return ExitStatus(r);
}

Register reg({"build", "build a release (database) from a recipe", kUsage, Run});

// `drape verify --rebuild` rebuilds through this hook.
struct InstallRebuilder {
  InstallRebuilder() {
    SetRebuilder([](const RebuildRequest& req) {
      Recipe recipe;
      if (!req.recipe_path.empty()) {
        recipe = LoadRecipe(req.recipe_path);
      } else {
        const Release rel = Release::Open(req.release);
        const std::string text = rel.dataset().at("recipe").value("text", "");
        recipe = ParseRecipe(text, (req.release / "dataset.json").string() + ":recipe", req.release,
                             rel.SourceFiles().empty() ? nullptr : &rel.SourceFiles());
      }
      BuildOptions o;
      o.output = req.out;
      o.threads = req.threads;
      o.progress = ProgressMode::kPlain;
      const BuildReport r = RunBuild(recipe, o);
      if (!r.finalized) throw Error("rebuild did not finish: " + r.error);
    });
  }
} install_rebuilder;

}  // namespace
}  // namespace drape::cli
