#include "generator/pipeline/cost.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <queue>
#include <set>
#include <sstream>

#include "common/error.h"
#include "common/files.h"
#include "common/format.h"
#include "garments/io.h"
#include "generator/pipeline/build.h"

namespace fs = std::filesystem;

namespace drape {

namespace {

// What the job adds to its garment's drivers: material, fit, sensing, fusion.
void SetJobDrivers(const Recipe& recipe, const Job& job, JobDrivers& d) {
  const SensingSpec& s = recipe.sensing.at(job.sensing);
  d.material = job.material_name;
  d.fit_key = FitKey(job.material, HangOptionsFor(recipe, recipe.garments.at(job.garment)));
  d.frames = s.sweep.frames;
  d.fused_frames = (s.sweep.frames + recipe.fusion.frames_stride - 1) / std::max(1, recipe.fusion.frames_stride);
  d.voxels_per_metre = recipe.fusion.voxels_per_metre;
  d.keep_frames = s.keep_frames;
  d.noise = s.sweep.kinect.noise ? 1 : 0;
}

}  // namespace

JobDrivers DriversFor(const Recipe& recipe, const Job& job, const Garment& garment) {
  const GarmentSpec& g = recipe.garments.at(job.garment);
  JobDrivers d;
  d.template_name = g.template_name.empty() ? g.file.filename().string() : g.template_name;
  d.instance = job.instance_name + "@" + FormatNumber(job.size_scale);
  d.nodes = garment.mesh.NumVertices();
  d.faces = garment.mesh.NumFaces();
  d.area = FaceAreas(garment.mesh).sum();
  d.hang_ply_bytes = static_cast<int>(EncodeMesh(garment.mesh).size());
  SetJobDrivers(recipe, job, d);
  return d;
}

Json DriversJson(const JobDrivers& d) {
  return {{"template", d.template_name},
          {"material", d.material},
          {"instance", d.instance},
          {"fit", d.fit_key},
          {"nodes", d.nodes},
          {"faces", d.faces},
          {"area", d.area},
          {"frames", d.frames},
          {"fused_frames", d.fused_frames},
          {"voxels_per_metre", d.voxels_per_metre},
          {"keep_frames", d.keep_frames},
          {"hang_ply_bytes", d.hang_ply_bytes},
          {"noise", d.noise}};
}

JobDrivers DriversFromJson(const Json& j) {
  JobDrivers d;
  try {
    d.template_name = j.at("template").get<std::string>();
    d.material = j.at("material").get<std::string>();
    d.instance = j.at("instance").get<std::string>();
    d.fit_key = j.at("fit").get<std::string>();
    d.nodes = j.at("nodes").get<int>();
    d.faces = j.at("faces").get<int>();
    d.area = j.at("area").get<double>();
    d.frames = j.at("frames").get<int>();
    d.fused_frames = j.at("fused_frames").get<int>();
    d.voxels_per_metre = j.at("voxels_per_metre").get<double>();
    d.keep_frames = j.at("keep_frames").get<bool>();
    d.hang_ply_bytes = j.at("hang_ply_bytes").get<int>();
    d.noise = j.value("noise", -1);  // absent in records made before it was a driver
  } catch (const Json::exception& e) {
    throw Error(std::string("job cost record: ") + e.what());
  }
  return d;
}

// ---------------------------------------------------------------- records

namespace {

std::map<std::string, double> NumberMap(const Json& j) {
  std::map<std::string, double> m;
  if (j.is_object())
    for (const auto& [k, v] : j.items())
      if (v.is_number()) m[k] = v.get<double>();
  return m;
}

double NumberOr(const Json& j, const char* key, double fallback) {
  return j.is_object() && j.contains(key) && j[key].is_number() ? j[key].get<double>() : fallback;
}

}  // namespace

BuildCost ReadBuildCost(const fs::path& file) {
  Json b;
  try {
    b = Json::parse(ReadFile(file));
  } catch (const Json::exception& e) {
    throw Error(file.string() + ": not JSON (" + e.what() + ")");
  }
  BuildCost c;
  c.source = file.string();
  c.finished = b.value("finished", "");
  c.host = b.value("host", "");
  c.code_version = b.value("code_version", "");
  const Json costs = b.value("costs", Json::object());
  c.release = costs.value("release", "");
  c.cpu_model = b.value("provenance", Json::object()).value("cpu", "");
  c.probe_cpu = NumberOr(costs, "probe_cpu_seconds", -1);
  c.commit_cpu = NumberOr(costs, "commit_cpu_seconds", -1);
  c.finalize_cpu = NumberOr(costs, "finalize_cpu_seconds", -1);
  const Json bytes = costs.value("bytes", Json::object());
  c.viewer_mesh_bytes = NumberOr(bytes, "viewer_meshes", -1);
  c.fixed_bytes = NumberOr(bytes, "fixed", -1);
  c.per_entry_bytes = NumberOr(bytes, "per_entry", -1);
  c.entries_in_release = static_cast<int>(NumberOr(costs, "entries", 0));
  const Json timing = b.value("entry_timing", Json::object());
  for (const auto& [id, t] : timing.items()) {
    if (!t.is_object() || !t.contains("cpu") || !t.contains("job")) continue;
    EntryCost e;
    try {
      e.job = DriversFromJson(t["job"]);
    } catch (const Error& err) {
      throw Error(file.string() + ": entry_timing " + id + ": " + err.what());
    }
    e.cpu = NumberMap(t["cpu"]);
    e.bytes = NumberMap(t.value("bytes", Json::object()));
    e.failed = t.value("failed", false);
    for (const auto& [k, v] : e.bytes) c.entry_bytes += v;
    c.entries.push_back(std::move(e));
  }
  return c;
}

std::vector<BuildCost> FindBuildCosts(const fs::path& root, const std::vector<fs::path>& extra,
                                      std::vector<std::string>* notes) {
  std::vector<fs::path> files;
  std::error_code ec;
  const fs::path datasets = root / "datasets";
  if (fs::is_directory(datasets, ec)) {
    for (const auto& name : fs::directory_iterator(datasets, ec)) {
      if (!name.is_directory()) continue;
      for (const auto& version : fs::directory_iterator(name.path(), ec))
        for (const char* f : {"costs.json", "build.json"})
          if (fs::is_regular_file(version.path() / f)) files.push_back(version.path() / f);
    }
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& p : extra) files.push_back(fs::is_directory(p) ? p / "build.json" : p);
  std::map<std::string, BuildCost> latest;  // release (or file) → its last finished build
  for (const fs::path& f : files) {
    BuildCost c;
    try {
      c = ReadBuildCost(f);
    } catch (const Error& e) {
      if (notes) notes->push_back(std::string("skipped ") + e.what());
      continue;
    }
    if (c.entries.empty()) continue;
    const std::string key = c.release.empty() ? c.source : c.release;
    auto it = latest.find(key);
    if (it == latest.end() || it->second.finished < c.finished) latest[key] = std::move(c);
  }
  std::vector<BuildCost> out;
  out.reserve(latest.size());
  for (auto& [k, c] : latest) out.push_back(std::move(c));
  return out;
}

// ---------------------------------------------------------------- the model

namespace {

using Terms = std::function<std::vector<double>(const JobDrivers&)>;

// The terms of each stage's linear model (see cost.h).
const std::map<std::string, Terms>& StageTerms() {
  static const std::map<std::string, Terms> terms = {
      {"sweep",
       [](const JobDrivers& d) {
         return std::vector<double>{double(d.frames), double(d.frames) * d.nodes};
       }},
      {"fusion",
       [](const JobDrivers& d) {
         return std::vector<double>{double(d.fused_frames), double(d.fused_frames) * d.Surface()};
       }},
      {"accuracy",
       [](const JobDrivers& d) {
         return std::vector<double>{d.Surface(), double(d.nodes)};
       }},
      {"feature", [](const JobDrivers& d) { return std::vector<double>{d.Surface()}; }},
      {"encode",
       [](const JobDrivers& d) {
         return std::vector<double>{d.Surface(), double(d.nodes), d.keep_frames ? double(d.frames) : 0.0};
       }},
      {"preview",
       [](const JobDrivers& d) {
         return std::vector<double>{1.0, d.Surface(), double(d.nodes)};
       }},
  };
  return terms;
}

// Bytes of an entry's files: recon.ply and sdf.vdb by the surface, kept frames by their
// count, the others (feature.bin, preview.png) their mean.
const std::map<std::string, Terms>& FileTerms() {
  static const std::map<std::string, Terms> terms = {
      {"recon.ply", [](const JobDrivers& d) { return std::vector<double>{d.Surface()}; }},
      {"sdf.vdb", [](const JobDrivers& d) { return std::vector<double>{d.Surface()}; }},
      {"sweep", [](const JobDrivers& d) { return std::vector<double>{d.keep_frames ? double(d.frames) : 0.0}; }},
  };
  return terms;
}

// min |Xc − y|² over c >= 0, for the few terms of a stage: every subset of terms is
// solved by least squares and the best non-negative solution kept.
std::vector<double> NonNegativeLeastSquares(const std::vector<std::vector<double>>& X, const std::vector<double>& y) {
  const int k = X.empty() ? 0 : static_cast<int>(X[0].size());
  std::vector<double> best(k, 0.0);
  double best_err = std::inner_product(y.begin(), y.end(), y.begin(), 0.0);
  for (int mask = 1; mask < (1 << k); ++mask) {
    std::vector<int> cols;
    for (int j = 0; j < k; ++j)
      if (mask & (1 << j)) cols.push_back(j);
    Eigen::MatrixXd A(X.size(), cols.size());
    Eigen::VectorXd b(y.size());
    for (size_t i = 0; i < X.size(); ++i) {
      for (size_t c = 0; c < cols.size(); ++c) A(i, c) = X[i][cols[c]];
      b(i) = y[i];
    }
    // Columns scaled to unit norm: the terms differ by orders of magnitude.
    Eigen::VectorXd scale = A.colwise().norm().transpose();
    if ((scale.array() <= 0).any()) continue;
    const Eigen::VectorXd s = (A * scale.cwiseInverse().asDiagonal()).colPivHouseholderQr().solve(b);
    const Eigen::VectorXd c = s.cwiseQuotient(scale);
    if ((c.array() < 0).any() || !c.allFinite()) continue;
    const double err = (A * c - b).squaredNorm();
    if (err < best_err) {
      best_err = err;
      std::fill(best.begin(), best.end(), 0.0);
      for (size_t j = 0; j < cols.size(); ++j) best[cols[j]] = c(j);
    }
  }
  return best;
}

double Dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) s += a[i] * b[i];
  return s;
}

std::string Seconds(double s) { return s >= 0.1 ? FormatFixed(s, 2) + " s" : FormatFixed(s * 1e3, 2) + " ms"; }

}  // namespace

namespace {

using Coefs = std::map<std::string, std::vector<double>>;

// The stages and files whose cost the sweep's noise changes (cost.h).
bool NoiseDriven(const std::string& key) {
  return key == "sweep" || key == "fusion" || key == "file:recon.ply" || key == "file:sdf.vdb" ||
         key.rfind("mean file:", 0) == 0;
}
std::string NoiseKey(const std::string& key, int noise) { return key + (noise ? "|noisy" : "|noise-free"); }

// coef[key] over every record that measured `name` in `field` (cpu or bytes); for a
// noise-driven key also coef[NoiseKey(key, n)] over the records of each noise that say so,
// when there are at least 3.
void FitOne(const std::vector<const EntryCost*>& all, const std::string& key, const Terms& terms,
            std::map<std::string, double> EntryCost::*field, const std::string& name, Coefs& coef) {
  std::vector<std::vector<double>> X[3];  // all, noise-free, noisy
  std::vector<double> y[3];
  for (const EntryCost* e : all) {
    auto it = (e->*field).find(name);
    if (it == (e->*field).end()) continue;
    X[0].push_back(terms(e->job)), y[0].push_back(it->second);
    const int n = e->job.noise;
    if (n == 0 || n == 1) X[1 + n].push_back(terms(e->job)), y[1 + n].push_back(it->second);
  }
  coef[key] = NonNegativeLeastSquares(X[0], y[0]);
  if (!NoiseDriven(key)) return;
  for (int n : {0, 1})
    if (y[1 + n].size() >= 3) coef[NoiseKey(key, n)] = NonNegativeLeastSquares(X[1 + n], y[1 + n]);
}

// Each entry stage's and file's linear model, and the mean of the files without one.
void FitEntryStages(const std::vector<const EntryCost*>& all, Coefs& coef) {
  for (const auto& [stage, terms] : StageTerms()) FitOne(all, stage, terms, &EntryCost::cpu, stage, coef);
  for (const auto& [file, terms] : FileTerms()) FitOne(all, "file:" + file, terms, &EntryCost::bytes, file, coef);
  // Files of constant size (feature.bin) or about constant (preview.png): their mean.
  std::set<std::string> other;
  for (const EntryCost* e : all)
    for (const auto& [file, bytes] : e->bytes)
      if (!FileTerms().count(file) && file != "hang.ply") other.insert(file);
  const Terms one = [](const JobDrivers&) { return std::vector<double>{1.0}; };
  for (const std::string& file : other) FitOne(all, "mean file:" + file, one, &EntryCost::bytes, file, coef);
}

// The hang per node, by template and material, template, or all.
std::map<std::string, double> FitHangPerNode(const std::vector<const EntryCost*>& all) {
  std::map<std::string, std::array<double, 3>> hang;  // key → cpu, nodes, count
  for (const EntryCost* e : all) {
    auto it = e->cpu.find("hang");
    if (it == e->cpu.end()) continue;
    for (const std::string& key : {e->job.template_name + "/" + e->job.material, e->job.template_name, std::string()}) {
      auto& h = hang[key];
      h[0] += it->second, h[1] += e->job.nodes, h[2] += 1;
    }
  }
  std::map<std::string, double> per_node;
  for (const auto& [key, h] : hang)
    if (h[2] >= 3 || key.empty()) per_node[key] = h[0] / std::max(1.0, h[1]);
  return per_node;
}

// Once per instance / per material: the job that made it paid (the others waited).
void FitOncePerGarment(const std::vector<BuildCost>& builds, Coefs& coef) {
  std::vector<std::vector<double>> gX;
  std::vector<double> gy;
  double fit_sum = 0;
  int fits = 0;
  for (const BuildCost& b : builds) {
    std::map<std::string, std::pair<double, int>> garment;  // instance → max cpu, nodes
    std::map<std::string, double> fit;
    for (const EntryCost& e : b.entries) {
      auto& g = garment[e.job.instance];
      g.first = std::max(g.first, e.cpu.count("garment") ? e.cpu.at("garment") : 0.0), g.second = e.job.nodes;
      fit[e.job.fit_key] = std::max(fit[e.job.fit_key], e.cpu.count("fit") ? e.cpu.at("fit") : 0.0);
    }
    for (const auto& [k, g] : garment) gX.push_back({double(g.second)}), gy.push_back(g.first);
    for (const auto& [k, f] : fit) fit_sum += f, ++fits;
  }
  coef["garment"] = NonNegativeLeastSquares(gX, gy);
  coef["fit"] = {fits ? fit_sum / fits : 0.0};
}

// Build-level: commit per entry byte, finalize per release byte, the release's own files.
// False when no build recorded them.
bool FitBuildLevel(const std::vector<BuildCost>& builds, Coefs& coef) {
  double commit = 0, commit_bytes = 0, fin = 0, fin_bytes = 0, view = 0, view_mesh = 0, fixed = 0, per_entry = 0;
  int n_fixed = 0, n_entries = 0;
  for (const BuildCost& b : builds) {
    double mesh = 0;
    for (const EntryCost& e : b.entries)
      for (const char* f : {"hang.ply", "recon.ply"})
        if (auto it = e.bytes.find(f); it != e.bytes.end()) mesh += it->second;
    if (b.commit_cpu >= 0) commit += b.commit_cpu, commit_bytes += b.entry_bytes;
    if (b.viewer_mesh_bytes >= 0) view += b.viewer_mesh_bytes, view_mesh += mesh;
    if (b.fixed_bytes >= 0) fixed += b.fixed_bytes, ++n_fixed;
    if (b.per_entry_bytes >= 0)
      per_entry += b.per_entry_bytes * b.entries_in_release, n_entries += b.entries_in_release;
    if (b.finalize_cpu >= 0 && b.viewer_mesh_bytes >= 0) {
      fin += b.finalize_cpu;
      fin_bytes += b.entry_bytes + b.viewer_mesh_bytes + b.fixed_bytes + b.per_entry_bytes * b.entries_in_release;
    }
  }
  coef["commit"] = {commit_bytes > 0 ? commit / commit_bytes : 0.0};
  coef["finalize"] = {fin_bytes > 0 ? fin / fin_bytes : 0.0};
  coef["release:viewer_meshes"] = {view_mesh > 0 ? view / view_mesh : 0.0};
  coef["release:fixed"] = {n_fixed ? fixed / n_fixed : 0.0};
  coef["release:per_entry"] = {n_entries ? per_entry / n_entries : 0.0};
  return commit_bytes > 0 && fin_bytes > 0;
}

// The builds that carry a speed probe, their CPU seconds scaled to a machine whose probe
// took probe_cpu (cost.h); every build as it is when none carries one.
std::vector<BuildCost> ScaledToMachine(const std::vector<BuildCost>& builds, double probe_cpu,
                                       std::vector<std::string>* notes) {
  std::vector<BuildCost> scaled;
  for (const BuildCost& b : builds) {
    if (!(b.probe_cpu > 0)) continue;
    BuildCost s = b;
    const double r = probe_cpu / b.probe_cpu;
    for (EntryCost& e : s.entries)
      for (auto& [stage, cpu] : e.cpu) cpu *= r;
    if (s.commit_cpu > 0) s.commit_cpu *= r;
    if (s.finalize_cpu > 0) s.finalize_cpu *= r;
    scaled.push_back(std::move(s));
  }
  if (scaled.empty()) {
    notes->push_back("no record carries a speed probe: priced in the CPU seconds of the machines that built them");
    return builds;
  }
  if (scaled.size() < builds.size())
    notes->push_back(std::to_string(builds.size() - scaled.size()) +
                     " builds without a speed probe left out (their machine's speed is unknown)");
  return scaled;
}

}  // namespace

CostModel CostModel::Fit(const std::vector<BuildCost>& measured, double probe_cpu) {
  CostModel m;
  const std::vector<BuildCost> builds = probe_cpu > 0 ? ScaledToMachine(measured, probe_cpu, &m.notes_) : measured;
  m.scaled_ = probe_cpu > 0 && !builds.empty() && builds.front().probe_cpu > 0;
  std::vector<const EntryCost*> all;
  for (const BuildCost& b : builds)
    for (const EntryCost& e : b.entries) all.push_back(&e);
  m.records_ = static_cast<int>(all.size());
  if (all.empty()) return m;

  FitEntryStages(all, m.coef_);
  m.hang_per_node_ = FitHangPerNode(all);
  FitOncePerGarment(builds, m.coef_);
  if (!FitBuildLevel(builds, m.coef_))
    m.notes_.push_back("no build-level costs (commit, finalize, the release's own files) among the records: left out");

  std::set<std::string> names;
  for (const BuildCost& b : builds)
    names.insert((b.release.empty() ? b.source : b.release) + " (" + std::to_string(b.entries.size()) + " entries, " +
                 b.source +
                 (m.scaled_ ? ", CPU × " + FormatFixed(probe_cpu / b.probe_cpu, 2) + " by the speed probe" : "") + ")");
  for (const std::string& n : names) m.notes_.push_back("measured: " + n);
  return m;
}

std::map<std::string, std::string> CostModel::Describe() const {
  std::map<std::string, std::string> d;
  if (empty()) return d;
  auto c = [&](const std::string& k, size_t i) { return coef_.at(k).size() > i ? coef_.at(k)[i] : 0.0; };
  std::string hang;
  for (const auto& [key, k] : hang_per_node_)
    hang += (hang.empty() ? "" : ", ") + (key.empty() ? std::string("all") : key) + " " + Seconds(k);
  d["hang"] = "per node: " + hang;
  d["sweep"] = Seconds(c("sweep", 0)) + "/frame + " + Seconds(c("sweep", 1) * 1e3) + "/(frame·1000 nodes)";
  d["fusion"] = Seconds(c("fusion", 0)) + "/fused frame + " + Seconds(c("fusion", 1) * 1e6) + "/(frame·10⁶ S)";
  d["accuracy"] = Seconds(c("accuracy", 0) * 1e6) + "/10⁶ S + " + Seconds(c("accuracy", 1) * 1e3) + "/1000 nodes";
  d["feature"] = Seconds(c("feature", 0) * 1e6) + "/10⁶ S";
  d["encode"] = Seconds(c("encode", 0) * 1e6) + "/10⁶ S + " + Seconds(c("encode", 1) * 1e3) + "/1000 nodes + " +
                Seconds(c("encode", 2)) + "/kept frame";
  d["preview"] = Seconds(c("preview", 0)) + " + " + Seconds(c("preview", 1) * 1e6) + "/10⁶ S + " +
                 Seconds(c("preview", 2) * 1e3) + "/1000 nodes";
  d["garment"] = Seconds(c("garment", 0) * 1e3) + "/1000 nodes, once per instance";
  d["fit"] = Seconds(c("fit", 0)) + " once per material (as jittered)";
  d["commit"] = Seconds(c("commit", 0) * 1e6) + "/MB";
  d["finalize"] = Seconds(c("finalize", 0) * 1e6) + "/MB";
  return d;
}

const std::vector<double>& CostModel::Coef(const std::string& key, const JobDrivers& d) const {
  if (d.noise >= 0)
    if (auto it = coef_.find(NoiseKey(key, d.noise)); it != coef_.end()) return it->second;
  return coef_.at(key);
}

std::map<std::string, double> CostModel::JobCpu(const JobDrivers& d, bool* fallback) const {
  std::map<std::string, double> cpu;
  if (empty()) return cpu;
  for (const auto& [stage, terms] : StageTerms()) cpu[stage] = Dot(Coef(stage, d), terms(d));
  std::string key = d.template_name + "/" + d.material;
  if (!hang_per_node_.count(key)) key = d.template_name;
  if (!hang_per_node_.count(key)) key.clear();
  if (fallback) *fallback = key.empty();
  auto it = hang_per_node_.find(key);
  cpu["hang"] = it == hang_per_node_.end() ? 0.0 : it->second * d.nodes;
  return cpu;
}

std::map<std::string, double> CostModel::JobBytes(const JobDrivers& d) const {
  std::map<std::string, double> bytes;
  if (empty()) return bytes;
  bytes["hang.ply"] = d.hang_ply_bytes;
  for (const auto& [file, terms] : FileTerms()) {
    const double b = Dot(Coef("file:" + file, d), terms(d));
    if (b > 0) bytes[file] = b;
  }
  for (const auto& [k, c] : coef_)
    if (k.rfind("mean file:", 0) == 0 && k.find('|') == std::string::npos) bytes[k.substr(10)] = Coef(k, d)[0];
  return bytes;
}

double CostModel::GarmentCpu(const JobDrivers& d) const { return empty() ? 0 : coef_.at("garment")[0] * d.nodes; }
double CostModel::FitCpu(const JobDrivers&) const { return empty() ? 0 : coef_.at("fit")[0]; }
double CostModel::CommitCpu(double entry_bytes) const { return empty() ? 0 : coef_.at("commit")[0] * entry_bytes; }
double CostModel::FinalizeCpu(double release_bytes) const {
  return empty() ? 0 : coef_.at("finalize")[0] * release_bytes;
}
double CostModel::ReleaseBytes(int entries, double mesh_bytes) const {
  if (empty()) return 0;
  return coef_.at("release:fixed")[0] + coef_.at("release:per_entry")[0] * entries +
         coef_.at("release:viewer_meshes")[0] * mesh_bytes;
}

// ---------------------------------------------------------------- plan

namespace {

// Garments of one recipe garment made to read their nodes and area: the first few
// instances; the others take their mean (instances of a template differ by a few
// per cent), so that pricing thousands of instances takes seconds.
constexpr int kMadeInstances = 8;

// Each job's drivers: the instance's garment (made, or the mean of its garment's made
// instances), the job's material and sensing.
std::vector<JobDrivers> PlanDrivers(const Recipe& recipe, const std::vector<Job>& all_jobs,
                                    const std::vector<int>& jobs, std::vector<std::string>* notes) {
  std::map<std::string, JobDrivers> instance_drivers;  // instance@scale → drivers
  std::map<int, std::vector<JobDrivers>> made;         // recipe garment → drivers of made instances
  std::map<int, std::set<std::string>> estimated;      // recipe garment → instances estimated
  std::vector<JobDrivers> out;
  for (int i : jobs) {
    const Job& job = all_jobs.at(i);
    const std::string ikey = job.instance_name + "@" + FormatNumber(job.size_scale);
    auto it = instance_drivers.find(ikey);
    if (it == instance_drivers.end()) {
      std::vector<JobDrivers>& m = made[job.garment];
      JobDrivers d;
      if (static_cast<int>(m.size()) < kMadeInstances) {
        d = DriversFor(recipe, job, MakeJobGarment(recipe, job));
        m.push_back(d);
      } else {
        d = m[0];
        double nodes = 0, faces = 0, area = 0, ply = 0;
        for (const JobDrivers& x : m) nodes += x.nodes, faces += x.faces, area += x.area, ply += x.hang_ply_bytes;
        const double n = static_cast<double>(m.size());
        d.nodes = static_cast<int>(std::lround(nodes / n)), d.faces = static_cast<int>(std::lround(faces / n));
        d.area = area / n * job.size_scale * job.size_scale, d.hang_ply_bytes = static_cast<int>(std::lround(ply / n));
        d.instance = ikey;
        estimated[job.garment].insert(ikey);
      }
      it = instance_drivers.emplace(ikey, d).first;
    }
    JobDrivers d = it->second;  // the instance's garment; the job's own drivers below
    SetJobDrivers(recipe, job, d);
    out.push_back(d);
  }
  for (const auto& [g, e] : estimated)
    notes->push_back(recipe.garments.at(g).name + ": nodes and area of " + std::to_string(e.size()) +
                     " instances taken as the mean of the first " + std::to_string(kMadeInstances) + " made");
  return out;
}

}  // namespace

BuildPlan PlanBuild(const Recipe& recipe, const std::vector<Job>& all_jobs, const std::vector<int>& jobs, int threads,
                    const CostModel& model) {
  BuildPlan p;
  p.jobs = static_cast<int>(jobs.size());
  p.threads = std::max(1, std::min(threads, std::max(1, p.jobs)));
  std::set<int> with_jobs;
  for (int i : jobs) {
    ++p.jobs_per_split[all_jobs.at(i).split][recipe.garments.at(all_jobs.at(i).garment).name];
    with_jobs.insert(all_jobs.at(i).garment);
  }
  for (int g : with_jobs) p.garments.push_back(recipe.garments.at(g).name);
  const std::vector<JobDrivers> drivers = PlanDrivers(recipe, all_jobs, jobs, &p.notes);

  // The pool hands out jobs in order; the first job of an instance makes its garment and
  // the first of a material fits it, while later ones wait for them (build.cpp's caches).
  std::priority_queue<double, std::vector<double>, std::greater<double>> free_at;
  for (int t = 0; t < p.threads; ++t) free_at.push(0.0);
  std::map<std::string, double> garment_ready, fit_ready;
  double entry_bytes = 0, mesh_bytes = 0, end = 0;
  std::set<std::string> unmeasured;
  for (const JobDrivers& d : drivers) {
    bool fallback = false;
    const std::map<std::string, double> cpu = model.JobCpu(d, &fallback);
    if (fallback && unmeasured.insert(d.template_name).second)
      p.notes.push_back("no measured hang of template '" + d.template_name +
                        "': priced at the mean per node over all templates");
    const std::map<std::string, double> bytes = model.JobBytes(d);
    double job = 0, own = 0;  // own: the garment and fit this job makes
    for (const auto& [stage, s] : cpu) p.stage_cpu[stage] += s, job += s;
    const double t0 = free_at.top();
    free_at.pop();
    double t = t0;
    if (auto it = garment_ready.find(d.instance); it == garment_ready.end()) {
      const double g = model.GarmentCpu(d);
      p.stage_cpu["garment"] += g, own += g, t += g;
      garment_ready[d.instance] = t;
    } else {
      t = std::max(t, it->second);
    }
    if (auto it = fit_ready.find(d.fit_key); it == fit_ready.end()) {
      const double f = model.FitCpu(d);
      p.stage_cpu["fit"] += f, own += f, t += f;
      fit_ready[d.fit_key] = t;
    } else {
      t = std::max(t, it->second);
    }
    double b = 0;
    for (const auto& [file, n] : bytes) p.file_bytes[file] += n, b += n;
    const double commit = model.CommitCpu(b);
    p.stage_cpu["commit"] += commit;
    entry_bytes += b;
    mesh_bytes +=
        (bytes.count("hang.ply") ? bytes.at("hang.ply") : 0) + (bytes.count("recon.ply") ? bytes.at("recon.ply") : 0);
    t += job + commit;
    p.job_cpu.push_back(job + own + commit);
    free_at.push(t);
    end = std::max(end, t);
  }
  const double release_bytes = model.ReleaseBytes(p.jobs, mesh_bytes);
  p.file_bytes["release"] = release_bytes;
  p.bytes = entry_bytes + release_bytes;
  const double finalize = model.FinalizeCpu(p.bytes);
  p.stage_cpu["finalize"] = finalize;
  for (const auto& [stage, s] : p.stage_cpu) p.cpu_seconds += s;
  p.wall_seconds = end + finalize;
  return p;
}

namespace {

std::string Megabytes(double b) { return FormatFixed(b / 1e6, b < 1e8 ? 1 : 0) + " MB"; }

std::vector<std::string> PricedFrom(const CostModel& model) {
  std::vector<std::string> from;
  for (const std::string& n : model.notes())
    if (n.rfind("measured: ", 0) == 0) from.push_back(n.substr(10));
  return from;
}

}  // namespace

void PrintPlan(std::ostream& out, const BuildPlan& p, const CostModel& model) {
  // Jobs per split (rows) and garment (columns).
  const std::vector<std::string>& garments = p.garments;
  std::vector<std::string> splits;
  for (const char* s : {"train", "calibration", "test"})
    if (p.jobs_per_split.count(s)) splits.push_back(s);
  for (const auto& [split, g] : p.jobs_per_split)
    if (std::find(splits.begin(), splits.end(), split) == splits.end()) splits.push_back(split);
  size_t w0 = 5;
  for (const auto& s : splits) w0 = std::max(w0, s.size());
  auto cell = [](const std::string& s, size_t w) { return std::string(w > s.size() ? w - s.size() : 0, ' ') + s; };
  out << "  " << std::string(w0, ' ');
  for (const auto& g : garments) out << "  " << cell(g, std::max<size_t>(g.size(), 4));
  out << "  " << cell("all", 5) << "\n";
  std::map<std::string, int> col;
  for (const auto& s : splits) {
    out << "  " << s << std::string(w0 - s.size(), ' ');
    int row = 0;
    for (const auto& g : garments) {
      const auto& m = p.jobs_per_split.at(s);
      const int n = m.count(g) ? m.at(g) : 0;
      row += n, col[g] += n;
      out << "  " << cell(std::to_string(n), std::max<size_t>(g.size(), 4));
    }
    out << "  " << cell(std::to_string(row), 5) << "\n";
  }
  out << "  all" << std::string(w0 - 3, ' ');
  for (const auto& g : garments) out << "  " << cell(std::to_string(col[g]), std::max<size_t>(g.size(), 4));
  out << "  " << cell(std::to_string(p.jobs), 5) << "\n";
  if (model.empty()) {
    out << "  no measured costs to price it with: build a release first (its build.json records them), or pass\n"
           "  --costs RELEASE; published ones are read from datasets/*/*/costs.json under the working folder\n";
    return;
  }
  out << "  expected on " << p.threads << " thread" << (p.threads > 1 ? "s" : "") << ": "
      << FormatDuration(p.wall_seconds) << " wall (on " << p.threads << " idle core" << (p.threads > 1 ? "s" : "")
      << "), " << std::lround(p.cpu_seconds) << " CPU-s (" << FormatFixed(p.cpu_seconds / 3600, 2) << " CPU-h), "
      << Megabytes(p.bytes) << " on disk\n";
  out << "  CPU by stage:";
  std::vector<std::pair<double, std::string>> stages;
  for (const auto& [k, v] : p.stage_cpu) stages.push_back({v, k});
  std::sort(stages.rbegin(), stages.rend());
  for (const auto& [v, k] : stages)
    out << " " << k << " " << (v >= 10 ? std::to_string(std::lround(v)) : FormatFixed(v, 1)) << " s ("
        << std::lround(100 * v / std::max(1e-9, p.cpu_seconds)) << "%)";
  out << "\n  bytes by file:";
  std::vector<std::pair<double, std::string>> files;
  for (const auto& [k, v] : p.file_bytes) files.push_back({v, k == "release" ? "gallery, catalog, card" : k});
  std::sort(files.rbegin(), files.rend());
  for (const auto& [v, k] : files) out << " " << k << " " << Megabytes(v);
  out << "\n  priced from " << model.records() << " measured entries ("
      << (model.scaled() ? "CPU seconds scaled to this machine by the speed probe"
                         : "CPU seconds of the machine that built them")
      << "):\n";
  for (const std::string& f : PricedFrom(model)) out << "    " << f << "\n";
  for (const std::string& n : p.notes) out << "  note: " << n << "\n";
  for (const std::string& n : model.notes())
    if (n.rfind("measured: ", 0) != 0) out << "  note: " << n << "\n";
}

Json PlanJson(const BuildPlan& p, const CostModel& model) {
  Json per_split = Json::object();
  for (const auto& [split, g] : p.jobs_per_split) per_split[split] = Json(g);
  Json notes = Json(p.notes);
  for (const std::string& n : model.notes())
    if (n.rfind("measured: ", 0) != 0) notes.push_back(n);
  return {{"jobs", p.jobs},
          {"threads", p.threads},
          {"jobs_per_split", per_split},
          {"wall_s", model.empty() ? Json() : Json(p.wall_seconds)},
          {"cpu_s", model.empty() ? Json() : Json(p.cpu_seconds)},
          {"bytes", model.empty() ? Json() : Json(p.bytes)},
          {"stage_cpu_s", Json(p.stage_cpu)},
          {"file_bytes", Json(p.file_bytes)},
          {"priced_from", PricedFrom(model)},
          {"notes", notes}};
}

// ---------------------------------------------------------------- ETA

EtaClock::EtaClock(std::vector<double> predicted, int workers)
    : predicted_(std::move(predicted)), done_(predicted_.size(), false), workers_(std::max(1, workers)) {
  modelled_ = !predicted_.empty() && std::all_of(predicted_.begin(), predicted_.end(), [](double p) { return p > 0; });
  if (!modelled_) std::fill(predicted_.begin(), predicted_.end(), 1.0);
  remaining_predicted_ = std::accumulate(predicted_.begin(), predicted_.end(), 0.0);
}

void EtaClock::Done(int k, double wall_seconds) {
  if (k < 0 || k >= static_cast<int>(predicted_.size()) || done_[k]) return;
  done_[k] = true;
  remaining_predicted_ -= predicted_[k];
  done_predicted_ += predicted_[k];
  done_wall_ += wall_seconds;
}

double EtaClock::Remaining() const {
  // Wall seconds per modelled CPU second so far (1 on idle cores before any job ends).
  double speed = 1;
  if (done_predicted_ > 0)
    speed = done_wall_ / done_predicted_;
  else if (!modelled_)
    return NAN;
  return std::max(0.0, remaining_predicted_) * speed / workers_;
}

}  // namespace drape
