// The release model of the unfolding loop (release_model.h).
#include "runtime/unfolding/release_model.h"

#include <algorithm>
#include <map>
#include <mutex>

#include "common/error.h"
#include "garments/io.h"
#include "generator/recipe/jobs.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/release_source.h"

namespace drape::unfolding {

namespace fs = std::filesystem;
namespace rec = drape::recognition;

struct ReleaseModel::Impl {
  Release release;
  Recipe recipe;
  rec::Database db;
  std::optional<rec::Weights> weights;
  std::unique_ptr<rec::Recognizer> weighted, unweighted;
  rec::AnchorUvMap uvs;
  mutable std::mutex mu;
  mutable std::map<int, TriMesh> meshes;
  mutable std::map<std::string, TestGarment> tests;
  explicit Impl(const fs::path& dir) : release(Release::Open(dir)) {}
};

ReleaseModel::ReleaseModel(const fs::path& dir, const fs::path& weights_path) : impl_(std::make_unique<Impl>(dir)) {
  Impl& m = *impl_;
  const std::string text = m.release.dataset().value("recipe", Json::object()).value("text", "");
  if (text.empty())
    throw Error(dir.string() + "/dataset.json: no recipe text (needed for the test garments and sensing)");
  m.recipe = ParseRecipe(text, (dir / "dataset.json").string() + " (recipe)", dir);
  rec::LoadReport lr;
  m.db = rec::LoadDatabase(m.release, &lr);
  if (!weights_path.empty()) m.weights = rec::LoadWeights(weights_path, m.release.digest());
  m.weighted = std::make_unique<rec::Recognizer>(m.db, m.weights ? &*m.weights : nullptr);
  m.unweighted = std::make_unique<rec::Recognizer>(m.db, nullptr);
  m.uvs = rec::AnchorUvs(m.release);
}

ReleaseModel::~ReleaseModel() = default;
const Release& ReleaseModel::release() const { return impl_->release; }
const Recipe& ReleaseModel::recipe() const { return impl_->recipe; }
const rec::Database& ReleaseModel::database() const { return impl_->db; }
const rec::Weights* ReleaseModel::weights() const { return impl_->weights ? &*impl_->weights : nullptr; }
const rec::Recognizer& ReleaseModel::recognizer(bool weighted) const {
  return weighted ? *impl_->weighted : *impl_->unweighted;
}

const TriMesh& ReleaseModel::HungMesh(int entry) const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  auto it = impl_->meshes.find(entry);
  if (it == impl_->meshes.end()) {
    const std::string& id = impl_->db.label(entry).id;
    it = impl_->meshes.emplace(entry, ReadMesh(impl_->release.EntryPath(id, "hang.ply"))).first;
  }
  return it->second;
}

std::vector<AnchorPoint> ReleaseModel::InstanceAnchors(const std::string& instance) const {
  std::vector<AnchorPoint> out;
  for (const auto& [key, uv] : impl_->uvs)
    if (key.first == instance) out.push_back({key.second, uv});
  return out;
}

std::optional<Vec2> ReleaseModel::AnchorUv(const std::string& instance, const std::string& anchor) const {
  const auto it = impl_->uvs.find({instance, anchor});
  if (it == impl_->uvs.end()) return std::nullopt;
  return it->second;
}

int ReleaseModel::AnchorVertex(const std::string& instance, const std::string& anchor) const {
  for (int i = 0; i < impl_->db.size(); ++i) {
    const rec::EntryLabel& l = impl_->db.label(i);
    if (l.instance == instance && l.anchor == anchor) return l.anchor_vertex;
  }
  return -1;
}

std::vector<std::string> ReleaseModel::TestCategories() const {
  std::vector<std::string> out;
  for (const Job& j : ExpandJobs(impl_->recipe)) {
    if (j.split != "test") continue;
    const GarmentSpec& g = impl_->recipe.garments[j.garment];
    const std::string c = g.template_name.empty() ? g.category : FindTemplate(g.template_name)->category;
    if (std::find(out.begin(), out.end(), c) == out.end()) out.push_back(c);
  }
  return out;
}

namespace {
// The material fit the build recorded for job `j` (entry.json "material_fit"), so a
// trial hangs the garment with the release's own cloth parameters and skips
// FitMaterial's reference runs (minutes of CPU on the paper recipe). None when the
// entry is absent or failed, or its record has no fit.
std::optional<MaterialFit> RecordedFit(const Release& release, const Job& j) {
  const Release::EntryInfo* e = release.Find(j.id);
  if (!e || e->failed || !e->record.contains("material_fit")) return std::nullopt;
  const Json& f = e->record["material_fit"];
  if (!f.is_object() || !f.contains("stiffness") || !f.contains("friction")) return std::nullopt;
  MaterialFit fit;
  fit.stiffness = f["stiffness"].get<double>();
  fit.friction = f["friction"].get<double>();
  fit.target_stretch_percent = f.value("target_stretch_percent", 0.0);
  fit.reproduced_stretch_percent = f.value("reproduced_stretch_percent", 0.0);
  fit.converged = f.value("converged", false);
  fit.target_friction_deg = f.value("target_friction_deg", 0.0);
  fit.reproduced_friction_deg = f.value("reproduced_friction_deg", 0.0);
  if (!(fit.stiffness > 0 && fit.stiffness <= 1) || !(fit.friction >= 0))
    throw Error(release.dir().string() + "/entries/" + j.id + "/entry.json: material_fit out of range (stiffness " +
                std::to_string(fit.stiffness) + ", friction " + std::to_string(fit.friction) + ")");
  fit.note = "recorded by the release build";
  return fit;
}
}  // namespace

const ReleaseModel::TestGarment& ReleaseModel::TestInstance(const std::string& category) const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  auto it = impl_->tests.find(category);
  if (it != impl_->tests.end()) return it->second;
  const Recipe& r = impl_->recipe;
  for (const Job& j : ExpandJobs(r)) {
    if (j.split != "test") continue;
    const GarmentSpec& g = r.garments[j.garment];
    Garment garment = MakeJobGarment(r, j);
    if (garment.category != category) continue;
    TestGarment t;
    t.garment = std::move(garment);
    t.material = j.material;
    t.hang = HangOptionsFor(r, g);
    const std::optional<MaterialFit> recorded = RecordedFit(impl_->release, j);
    t.fit = recorded ? *recorded : FitMaterial(t.material, t.hang);
    t.instance = j.instance_name;
    return impl_->tests.emplace(category, std::move(t)).first->second;
  }
  throw Error(impl_->release.dir().string() + ": the release's test split has no garment of category '" + category +
              "' to unfold");
}

SweepOptions ReleaseModel::TestSensing() const {
  const Recipe& r = impl_->recipe;
  std::string name;
  for (const auto& s : r.splits)
    if (s.name == "test") name = s.sensing;
  auto it = r.sensing.find(name);
  if (it == r.sensing.end()) it = r.sensing.find("sensed");
  return it == r.sensing.end() ? SweepOptions{} : it->second.sweep;
}

}  // namespace drape::unfolding
