// What a build costs, priced from what earlier builds measured.
//
// Every entry's timing (build.json "entry_timing", never hashed) records, beside the
// wall time of each stage, its CPU time ("cpu": the job thread's, per stage), what drives
// its cost ("job": garment nodes and area, frames, voxels per metre) and its files'
// bytes ("bytes"); build.json "costs" adds the build's own: commit and finalize CPU, the
// release's bytes outside the entries, the process's CPU. A CostModel fits one small
// linear model per stage to every such record it is given (CPU seconds of the machine
// that measured them) and prices a recipe's jobs: `drape build --dry-run` prints it,
// and the build's progress line takes its ETA from it.
//
// The models (each fitted by non-negative least squares over the records; S = garment
// area × voxels per metre², about the surface's voxels):
//   hang      k × nodes, k per template and material (per template, or over all of
//             them, when fewer than 3 hangs of the pair were measured)
//   sweep     a × frames + b × frames × nodes          fusion  a × fused frames + b × fused frames × S
//   accuracy  a × S + b × nodes                         feature a × S
//   encode    a × S + b × nodes + c × kept frames       preview a + b × S + c × nodes
//   garment   a × nodes, once per instance              fit     the mean fit, once per FitKey
//   commit    a × entry bytes                           finalize a × release bytes
//   bytes     hang.ply exact (the garment's own PLY), recon.ply and sdf.vdb a × S,
//             kept sweeps a × frames, other files their mean; the gallery's mesh scripts
//             a × (hang.ply + recon.ply), the release's other files per entry and fixed.
// The sweep, the fusion, recon.ply, sdf.vdb and the files priced at their mean (the
// preview) are fitted apart for noisy and noise-free sweeps (a noise-free sweep costs less
// and fuses into smaller files) wherever the records hold at least 3 entries of that kind
// that say which; otherwise over all records.
#pragma once

#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "common/json.h"
#include "garments/garment.h"
#include "generator/recipe/jobs.h"
#include "generator/recipe/recipe.h"

namespace drape {

// What drives a job's cost, known before it runs (from the recipe and its garment).
struct JobDrivers {
  std::string template_name;  // the garment's template (file name for imports)
  std::string material;       // the recipe's material name
  std::string instance;       // the garment instance (made once per build)
  std::string fit_key;        // the material fit, FitKey (made once per build; jittered materials each their own)
  int nodes = 0, faces = 0;   // garment mesh
  double area = 0;            // garment mesh area, m² (both layers)
  int frames = 0;             // depth frames swept
  int fused_frames = 0;       // frames fused (every frames_stride-th)
  double voxels_per_metre = 0;
  bool keep_frames = false;
  int hang_ply_bytes = 0;  // the hung mesh's PLY: the garment's topology, so known exactly
  int noise = -1;          // the sweep's Kinect noise: 1 on, 0 off, -1 not recorded (records before it)

  double Surface() const { return area * voxels_per_metre * voxels_per_metre; }
};
JobDrivers DriversFor(const Recipe& recipe, const Job& job, const Garment& garment);
Json DriversJson(const JobDrivers& d);
JobDrivers DriversFromJson(const Json& j);  // throws drape::Error on a missing field

// One measured entry and one measured build.
struct EntryCost {
  JobDrivers job;
  std::map<std::string, double> cpu;    // stage → CPU seconds
  std::map<std::string, double> bytes;  // file ("sweep" for every kept frame) → bytes
  bool failed = false;
};
struct BuildCost {
  std::string source;   // file it was read from
  std::string release;  // "name version"
  std::string finished, host, cpu_model, code_version;
  double probe_cpu = -1;           // SpeedProbeCpuSeconds where it was built (< 0: not measured)
  std::vector<EntryCost> entries;  // entries whose timing carries "cpu" and "job"
  // Build-level (absent, < 0, in builds without "costs", e.g. merges of shards).
  double commit_cpu = -1, finalize_cpu = -1;
  double entry_bytes = 0;         // all entries' files
  double viewer_mesh_bytes = -1;  // viewer/meshes/
  double fixed_bytes = -1;        // viewer's libraries, README.md, dataset.json
  double per_entry_bytes = -1;    // entry.json, catalog, index.html, SHA256SUMS, per entry
  int entries_in_release = 0;
};

// Reads a build.json (a release's, or one published as datasets/<name>/<version>/costs.json).
// Entries without cost records (builds before them) are left out. Throws drape::Error
// naming the file if it is not JSON.
BuildCost ReadBuildCost(const std::filesystem::path& file);

// The records `drape build --dry-run` prices with: every datasets/*/*/costs.json and
// datasets/*/*/build.json under `root` (published costs and releases built into their
// default folder), plus `extra` (release folders or JSON files); of several records of
// one release, the last finished. Unreadable files are skipped with a note.
std::vector<BuildCost> FindBuildCosts(const std::filesystem::path& root,
                                      const std::vector<std::filesystem::path>& extra, std::vector<std::string>* notes);

// How fast this machine runs what builds spend most on: the CPU seconds of a fixed cloth
// simulation (a small two-layer sheet falling from a corner: Bullet's step, hinge
// bending, self-collision; ~50 ms, the least of five runs after a warm-up). Every build records it in
// build.json "costs" (probe_cpu_seconds); machines differ by 2.5x and more (an AMD EPYC
// against an Intel Xeon on the quickstart), so CPU seconds measured on one are priced on
// another only through it.
double SpeedProbeCpuSeconds();

class CostModel {
 public:
  // Fits every stage's model to the records (empty model when there are none). With
  // probe_cpu > 0 (SpeedProbeCpuSeconds of the machine to price for), the records that
  // carry a probe are scaled to it (CPU × probe_cpu / theirs) and those without one are
  // left out, unless none carries one; probe_cpu ≤ 0 takes every record as measured.
  static CostModel Fit(const std::vector<BuildCost>& builds, double probe_cpu = -1);
  // True when the records were scaled to a machine by its speed probe.
  bool scaled() const { return scaled_; }

  bool empty() const { return records_ == 0; }
  int records() const { return records_; }
  // What was fitted from what, and where data was missing ("no measured hang of template
  // X: the mean over all templates").
  const std::vector<std::string>& notes() const { return notes_; }
  // One line per stage: its coefficients, for the dry run's table.
  std::map<std::string, std::string> Describe() const;

  // A job's CPU seconds per stage (without its instance's garment and material fit) and
  // its files' bytes. `fallback` (optional) is set when no hang of the job's template
  // was measured and the mean per node over all templates priced it.
  std::map<std::string, double> JobCpu(const JobDrivers& d, bool* fallback = nullptr) const;
  std::map<std::string, double> JobBytes(const JobDrivers& d) const;
  double GarmentCpu(const JobDrivers& d) const;
  double FitCpu(const JobDrivers& d) const;
  double CommitCpu(double entry_bytes) const;
  double FinalizeCpu(double release_bytes) const;
  // Bytes of the release outside the entries' files.
  double ReleaseBytes(int entries, double mesh_bytes) const;

 private:
  // A stage's or file's coefficients for this job: its sweep's noise's own when fitted.
  const std::vector<double>& Coef(const std::string& key, const JobDrivers& d) const;

  int records_ = 0;
  bool scaled_ = false;
  std::vector<std::string> notes_;
  std::map<std::string, std::vector<double>> coef_;  // stage or file → coefficients of its terms
  std::map<std::string, double> hang_per_node_;      // "template/material", "template", "" (all)
};

// The price of building a recipe's jobs (or a shard's) on `threads` threads.
struct BuildPlan {
  int jobs = 0, threads = 1;
  std::map<std::string, std::map<std::string, int>> jobs_per_split;  // split → garment → jobs
  std::vector<std::string> garments;                                 // with jobs, in recipe order
  std::vector<double> job_cpu;                                       // per job, garment and fit included
  std::map<std::string, double> stage_cpu;                           // stage → CPU seconds
  double cpu_seconds = 0;                                            // all stages + commit + finalize
  double wall_seconds = 0;                   // on `threads` idle cores: the pool's schedule + finalize
  double bytes = 0;                          // the finished release folder
  std::map<std::string, double> file_bytes;  // entry files by name, "release" for the rest
  std::vector<std::string> notes;            // e.g. templates priced without a measured hang
};
// `jobs`: the jobs to price (indices into ExpandJobs(recipe)); garments are made once per
// instance to read their nodes, area and PLY size.
BuildPlan PlanBuild(const Recipe& recipe, const std::vector<Job>& all_jobs, const std::vector<int>& jobs, int threads,
                    const CostModel& model);
// The dry run's report: jobs per split and garment, the expected wall time (idle cores),
// CPU time and bytes, CPU per stage, what it was priced from.
void PrintPlan(std::ostream& out, const BuildPlan& plan, const CostModel& model);
// The same as JSON: jobs, threads, jobs_per_split, wall_s, cpu_s, bytes, stage_cpu_s,
// file_bytes, priced_from, notes.
Json PlanJson(const BuildPlan& plan, const CostModel& model);

// The ETA of a running build: the model's price of the jobs still to run, scaled by how
// the finished jobs' wall time compared with their price (a loaded machine, another
// CPU); with no model every job costs the same and this is the mean job time.
class EtaClock {
 public:
  EtaClock(std::vector<double> predicted, int workers);
  void Done(int k, double wall_seconds);  // job k (index into `predicted`) finished
  double Remaining() const;               // seconds, NaN until known

 private:
  std::vector<double> predicted_;
  std::vector<bool> done_;
  int workers_;
  double remaining_predicted_ = 0, done_predicted_ = 0, done_wall_ = 0;
  bool modelled_ = false;
};

}  // namespace drape
