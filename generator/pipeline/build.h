// The build: recipe → jobs → per-job pipeline (garment, material fit, hang, sweep,
// fusion, accuracy, feature, preview) → entries → release writer.
//
// Determinism: an entry depends only on the recipe and its job (seeds come from
// DeriveSeed(recipe seed, job key)); caches (garment per instance, material fit per
// material) hold deterministic values, so entries are byte-identical for any thread
// count, shard layout or resume history. Wall times go to Entry::timing only.
#pragma once

#include <atomic>
#include <filesystem>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "common/timing.h"
#include "generator/pipeline/cost.h"
#include "generator/recipe/jobs.h"
#include "generator/recipe/recipe.h"
#include "generator/release/entry.h"
#include "generator/release/release.h"

namespace drape {

enum class ProgressMode { kAuto, kTty, kPlain, kQuiet };

struct BuildOptions {
  std::filesystem::path output;          // empty = datasets/<name>/<version>/ (relative to the working folder)
  int threads = 0;                       // jobs run at once; <= 0 = all cores
  bool resume = false;                   // expect an unfinished build in `output` (plain builds resume anyway)
  int shard_index = 1, shard_count = 1;  // shard K of N (1-based): jobs with index % N == K − 1
  // Without keep_going, an unexpected error in a job (a bug, bad input found late)
  // stops handing out jobs and fails the build (committed entries are kept for
  // --resume). With keep_going it becomes a failed entry like a numerical failure.
  // Numerical failures (hang not settled, NumericalError) are always failed entries.
  bool keep_going = false;
  ProgressMode progress = ProgressMode::kAuto;  // kAuto: TTY line if `log` is a terminal
  double progress_interval = 10;                // seconds between plain progress lines
  std::ostream* log = nullptr;                  // progress and summary (nullptr = std::cerr)
  const std::atomic<bool>* stop = nullptr;      // set (e.g. by SIGINT) → hand out no more jobs
  std::string code_version;                     // recorded in dataset.json; empty = this binary's git version
  // Prices the jobs for the progress line's ETA (generator/pipeline/cost.h); nullptr or
  // empty: every job counts the same (the mean job time so far).
  const CostModel* costs = nullptr;
};

struct BuildReport {
  std::filesystem::path output;
  int total_jobs = 0;                                         // in the recipe
  int shard_jobs = 0;                                         // this shard's share
  int already_done = 0;                                       // skipped: committed by an earlier (interrupted) run
  int built = 0;                                              // committed by this run
  int failed = 0;                                             // failed entries committed by this run
  std::vector<std::pair<std::string, std::string>> failures;  // job key, reason (this run)
  bool interrupted = false;                                   // stopped by `stop` before every job ran
  bool aborted = false;                                       // an unexpected job error stopped the build (see error)
  std::string error;
  bool finalized = false;
  std::string digest;                           // release digest, when finalized
  int release_failed = 0;                       // failed entries in the whole release, when finalized
  std::map<std::string, double> stage_seconds;  // summed wall time per stage (this run)
  double wall_seconds = 0;
  double commit_cpu_seconds = 0;  // committing this run's entries (hashing, writing)
};

// Caches shared by the jobs of one build (thread-safe): the garment of each
// instance and the material fit of each material.
class JobCache {
 public:
  JobCache();
  ~JobCache();
  struct Impl;
  std::unique_ptr<Impl> impl;
};

// Runs one job's pipeline. A hang that fails or a NumericalError gives a failed
// entry; other exceptions propagate. Thread-safe over distinct jobs.
Entry BuildEntry(const Recipe& recipe, const Job& job, JobCache& cache);

// Builds the recipe's jobs (this shard's, minus those already committed) into the
// release folder and finalizes it unless interrupted or aborted.
BuildReport RunBuild(const Recipe& recipe, const BuildOptions& options);

// What RunBuild (and the MPI build's rank 0) tells the release writer: recipe, job
// keys, this shard's keys (`shard` = indices into `jobs`), code version.
ReleaseMeta MakeReleaseMeta(const Recipe& recipe, const std::vector<Job>& jobs, const std::vector<int>& shard,
                            const BuildOptions& options);

// The start both builds share (thread pool and the MPI build's rank 0): the jobs, the
// release opened (or resumed) for this shard and the shard's jobs still to run (indices
// into `jobs`); sets report's output, total_jobs, shard_jobs and already_done.
struct BuildStart {
  std::vector<Job> jobs;
  std::vector<int> todo;
  std::unique_ptr<ReleaseWriter> writer;
};
BuildStart StartBuild(const Recipe& recipe, const BuildOptions& options, BuildReport& report);

// The progress line's clock for a build's jobs still to run (`start.todo`, in order):
// priced by options.costs when it holds a model, else every job the same.
EtaClock MakeEtaClock(const Recipe& recipe, const BuildStart& start, int workers, const BuildOptions& options);

// kAuto → kTty when `log` is std::cerr or std::cout on a terminal, else kPlain.
ProgressMode ResolveProgressMode(ProgressMode mode, const std::ostream& log);

// "drape build: NAME VERSION → OUT\n  N jobs[, shard i/n: M][, K already done (resuming)], T to run on "
// (the caller ends the line with what runs them).
void LogBuildStart(std::ostream& log, const Recipe& recipe, const BuildOptions& options, const BuildReport& report,
                   size_t todo);

// The entry that stands for a job whose error --keep-going tolerates: failed, "error: ...".
Entry FailedEntry(const Job& job, const std::string& error);

// A committed entry in the report: built or failed, and its stage times (not "total" or
// "mpi_rank").
void CountEntry(const Entry& entry, const Job& job, BuildReport& report);

// The "stage wall time (summed over jobs): ..." line of the build summary, and the hang's
// "hang CPU time (summed over jobs): ..." line, which names every part of the hang stage.
void LogStageSeconds(std::ostream& log, const std::map<std::string, double>& stage_seconds);

// The end of a build, shared by RunBuild and the MPI build's rank 0: records the stage
// times in build.json, logs them, and finalizes the release unless the build was
// aborted or interrupted (sets report.interrupted, finalized, digest, release_failed);
// a finalized release's build.json then gets "costs" (cost.h: commit and finalize CPU,
// the release's bytes outside the entries).
void FinishBuild(ReleaseWriter& writer, BuildReport& report, ProgressMode mode, std::ostream& log);

// A duration for people: "42s", "3m05s", "1h02m"; "--" when unknown (NaN, negative).
std::string FormatDuration(double seconds);

// The progress line of both builds (thread pool and MPI): "[done/total] F failed,
// 1m05s elapsed, ETA 3m10s" and a suffix, rewritten in place on a terminal (kTty),
// printed every `interval` seconds when it changed (kPlain), not at all (kQuiet).
class ProgressLine {
 public:
  ProgressLine(std::ostream& log, ProgressMode mode, double interval) : log_(log), mode_(mode), interval_(interval) {}
  // `over`: the last call (kTty ends the line, kPlain prints it if it changed).
  void Print(int done, int total, int failed, double elapsed, double eta, bool over, const std::string& suffix = "");

 private:
  std::ostream& log_;
  ProgressMode mode_;
  double interval_;
  Clock::time_point last_plain_ = Clock::now();
  int last_reported_ = -1;
};

// Default output folder: datasets/<name>/<version>.
std::filesystem::path DefaultOutput(const Recipe& recipe);

// The preview.png composite: hung mesh with the anchor marked, one colour-mapped
// depth frame (PNG bytes from RenderDepthPreview, may be empty) and the fused mesh,
// side by side; orthographic, object frame seen from +z. PNG bytes.
std::string RenderEntryPreview(const TriMesh& hung, const Vec3& anchor_position, const std::string& depth_png,
                               const TriMesh& recon, const std::string& title);

}  // namespace drape
