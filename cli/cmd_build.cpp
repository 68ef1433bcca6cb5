// drape build RECIPE [-o DIR] [-j N] [--resume] [--shard K/N] [--keep-going] [--quiet]
//             [--dry-run [--json] [--costs PATH]...]
#include <csignal>
#include <iostream>
#include <memory>
#include <regex>

#include "cli/command.h"
#include "cli/options.h"
#include "common/error.h"
#include "common/parallel.h"
#include "generator/pipeline/build.h"
#include "generator/pipeline/build_mpi.h"
#include "generator/pipeline/cost.h"
#include "generator/recipe/jobs.h"
#include "generator/recipe/recipe.h"
#include "generator/release/release.h"

namespace fs = std::filesystem;

namespace drape::cli {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void OnSigint(int) {
  g_stop.store(true);
  // A second Ctrl-C kills at once (every committed entry is already safe on disk).
  std::signal(SIGINT, SIG_DFL);
}

const char* kFooter = R"(Builds the release a recipe describes (recipes/README.md documents recipes).

Under mpirun (mpirun -np N drape build RECIPE -o DIR) rank 0 hands out jobs and writes
the release while ranks 1..N-1 simulate, one job each at a time (-j is ignored); same
release digest as a one-process build (docs/cluster.md).

Ctrl-C stops handing out jobs, lets running ones finish and commit, and exits; run the
same command (or add --resume) to continue. Exit status: 0 all entries built, 1 bad
input, 4 the release was built but some entries failed (listed), 5 stopped early
(interrupted, or an unexpected job error without --keep-going).)";

struct BuildArgs {
  std::string recipe, output, shard;
  int jobs = 0;
  bool resume = false, keep_going = false, quiet = false, dry_run = false, json = false;
  std::vector<std::string> costs;
};

// --shard K/N into its two numbers; "" when it reads, else what is wrong.
std::string ParseShard(const std::string& s, int* k, int* n) {
  std::smatch m;
  if (!std::regex_match(s, m, std::regex("([0-9]{1,9})/([0-9]{1,9})")))
    return "expected K/N (e.g. 2/8), got '" + s + "'";
  *k = std::stoi(m[1]);
  *n = std::stoi(m[2]);
  if (*n < 1 || *k < 1 || *k > *n) return "'" + s + "': need 1 <= K <= N";
  return "";
}

// The costs earlier builds measured: published ones (datasets/*/*/costs.json), releases
// built into datasets/, the output folder's own earlier build, --costs. probe_cpu: this
// machine's speed probe, to scale them to it (≤ 0: as measured).
CostModel MeasuredCosts(const BuildArgs& args, const fs::path& out, std::vector<std::string>* notes, double probe_cpu) {
  std::vector<fs::path> extra;
  for (const std::string& c : args.costs) {
    if (!fs::exists(c)) throw Error("--costs " + c + ": no such release or file");
    extra.push_back(c);
  }
  if (fs::is_regular_file(out / "build.json")) extra.push_back(out);
  return CostModel::Fit(FindBuildCosts(fs::current_path(), extra, notes), probe_cpu);
}

// --dry-run: the jobs and what building them would cost, as text or JSON.
int DryRun(const BuildArgs& args, const Recipe& recipe, const BuildOptions& o, const fs::path& out) {
  std::vector<std::string> notes;
  const CostModel costs = MeasuredCosts(args, out, &notes, SpeedProbeCpuSeconds());
  const std::vector<Job> jobs = ExpandJobs(recipe);
  const int threads = o.threads > 0 ? o.threads : HardwareThreads();
  const BuildPlan plan =
      PlanBuild(recipe, jobs, ShardJobs(static_cast<int>(jobs.size()), o.shard_index, o.shard_count), threads, costs);
  if (args.json) {
    Json j = PlanJson(plan, costs);
    j["recipe"] = args.recipe;
    j["output"] = out.string();
    for (const std::string& n : notes) j["notes"].push_back(n);
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << "drape build --dry-run: " << recipe.name << " " << recipe.version << " -> " << out.string();
  if (o.shard_count > 1) std::cout << ", shard " << o.shard_index << "/" << o.shard_count;
  std::cout << "\n";
  PrintPlan(std::cout, plan, costs);
  for (const std::string& n : notes) std::cout << "  note: " << n << "\n";
  return 0;
}

// Exit status of a build that did not throw (see kUsage).
int ExitStatus(const BuildReport& r) {
  if (r.aborted || r.interrupted) return 5;
  return r.release_failed > 0 ? 4 : 0;
}

int Run(const BuildArgs& args) {
  const Recipe recipe = LoadRecipe(args.recipe);
  // Under mpirun every rank runs this command; rank 0 speaks for all of them.
  const bool mpi = MpiRequested();
  const bool speaker = !mpi || MpiLaunchRank() == 0;
  if (speaker)
    for (const auto& w : recipe.warnings) std::cerr << "drape build: warning: " << w << "\n";

  BuildOptions o;
  if (!args.output.empty()) o.output = args.output;
  if (args.jobs > 0) o.threads = args.jobs;
  o.resume = args.resume;
  o.keep_going = args.keep_going;
  if (args.quiet) o.progress = ProgressMode::kQuiet;
  if (!args.shard.empty()) ParseShard(args.shard, &o.shard_index, &o.shard_count);
  if (args.json && !args.dry_run) throw Error("--json: only with --dry-run");
  const fs::path out = o.output.empty() ? DefaultOutput(recipe) : o.output;
  if (args.dry_run) return speaker ? DryRun(args, recipe, o, out) : 0;
  // For the progress line's ETA, as measured: the clock rescales by the jobs that finish.
  const CostModel costs = MeasuredCosts(args, out, nullptr, -1);
  o.costs = &costs;
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
  std::string again = "drape build " + args.recipe + " -o " + r.output.string() + " --resume";
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

Runner Setup(CLI::App& app) {
  auto a = std::make_shared<BuildArgs>();
  app.footer(kFooter);
  app.add_option("RECIPE", a->recipe, "the recipe (YAML)")->required();
  AddOutput(app, a->output, "output folder (default datasets/<name>/<version>/)");
  AddJobs(app, a->jobs, "jobs run at once (default: all cores); entries are identical for any N");
  app.add_flag("--resume", a->resume,
               "continue an interrupted build in the output folder (a plain build resumes one too)");
  app.add_option("--shard", a->shard, "build only jobs with index % N == K-1 (merge shards with drape merge)")
      ->type_name("K/N")
      ->check(CLI::Validator(
          [](std::string& s) {
            int k = 0, n = 0;
            return ParseShard(s, &k, &n);
          },
          ""));
  app.add_flag("--keep-going", a->keep_going, "turn unexpected per-job errors into failed entries instead of stopping");
  app.add_flag("--quiet", a->quiet, "no progress output");
  app.add_flag("--dry-run", a->dry_run,
               "build nothing: print the jobs per split and garment and the expected wall time (on -j idle "
               "cores), CPU time and disk size, priced by the costs earlier builds measured (each release's "
               "build.json; published ones in datasets/*/*/costs.json under the working folder)");
  app.add_flag("--json", a->json, "with --dry-run: the same as JSON (jobs, wall_s, cpu_s, bytes, ...)");
  app.add_option("--costs", a->costs, "also price with this release's (or build.json's) measured costs")
      ->type_name("PATH");
  return [a] { return Run(*a); };
}

Register reg({"build", "build a release (database) from a recipe", Setup});

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
