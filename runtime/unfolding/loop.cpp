// The regrasping loop (see loop.h) and the release model it runs against.
#include "runtime/unfolding/loop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "common/closest_point.h"
#include "common/error.h"
#include "common/rng.h"
#include "common/timing.h"
#include "garments/io.h"
#include "generator/recipe/jobs.h"
#include "runtime/folding/table.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/category_fit.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/release_source.h"
#include "runtime/unfolding/candidates.h"

namespace drape::unfolding {

namespace fs = std::filesystem;
namespace rec = drape::recognition;
namespace hw = drape::hardware;

namespace {
Json J(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }
Json J(const Vec2& v) { return Json::array({v.x(), v.y()}); }
}  // namespace

void LoopOptions::Validate() const {
  objective.Validate();
  refine.Validate();
  capture.Validate();
  lowest.Validate();
  hanging.Validate();
  if (max_regrasps < 1 || max_regrasps > 100) throw Error("unfold.max_regrasps: must be in 1..100");
  if (!(standoff > 0 && standoff < 0.4)) throw Error("unfold.standoff: must be in (0, 0.4) m");
  if (!(grasp_depth >= 0 && grasp_depth < 0.1)) throw Error("unfold.grasp_depth: must be in [0, 0.1) m");
  if (!(sensing_height == 0 || (sensing_height > 0.5 && sensing_height < 3)))
    throw Error("unfold.sensing_height: must be 0 (the release's rig) or in (0.5, 3) m");
  if (!(success_distance > 0)) throw Error("unfold.success_distance: must be > 0 m");
  if (plan_prior_top_k < 0 || plan_prior_top_k > 5) throw Error("unfold.plan_prior_top_k: must be in 0..5");
  if (candidates < 1 || candidates > 10) throw Error("unfold.candidates: must be in 1..10");
  if (!(refit_absent_penalty >= 0)) throw Error("unfold.refit_absent_penalty: must be >= 0");
}

double Coverage(const TriMesh& lying, const Garment& garment, double mpp) {
  TriMesh flat;
  flat.F = garment.mesh.F;
  flat.V = folding::LayFlat(garment.mesh, folding::TableOptions{});
  auto area = [mpp](const TriMesh& m) {
    const cv::Mat mask = folding::TopDownMask(m, folding::FrameCamera(m.V, mpp));
    return double(cv::countNonZero(mask));
  };
  const double a = area(flat);
  DRAPE_CHECK(a > 0, "the flat garment has no top-down area");
  return area(lying) / a;
}

namespace {
// Index of the first of the first n candidates whose anchor is `aimed` or a symmetry twin
// of it; -1 if none is, or `aimed` is empty.
int FirstAimedOrTwin(const std::vector<rec::Candidate>& list, size_t n, const std::string& aimed) {
  if (aimed.empty()) return -1;
  std::vector<std::string> accept = rec::SymmetryTwins(aimed);
  accept.push_back(aimed);
  n = std::min(n, list.size());
  for (size_t i = 0; i < n; ++i)
    if (std::find(accept.begin(), accept.end(), list[i].anchor) != accept.end()) return static_cast<int>(i);
  return -1;
}
}  // namespace

int PlanPriorRank(const rec::Recognition& r, const std::string& aimed, int top_k) {
  return FirstAimedOrTwin(r.top, static_cast<size_t>(std::max(top_k, 0)), aimed);
}

bool MayStop(const LoopOptions& o, double f, bool holder_regrasped) { return f >= o.objective.xi && holder_regrasped; }

int TrustedAimedEntry(const rec::Recognition& r, const std::string& aimed) {
  return FirstAimedOrTwin(r.entries, r.entries.size(), aimed);
}

double DesiredPairDistance(const Garment& g, const std::vector<DesiredPair>& pairs, const Vec2& a, const Vec2& b) {
  double best = -1;
  for (const DesiredPair& d : pairs) {
    const Anchor* l = g.FindAnchor(d.first);
    const Anchor* r = g.FindAnchor(d.second);
    if (!l || !r) continue;
    const double straight = std::max((a - l->uv).norm(), (b - r->uv).norm());
    const double crossed = std::max((a - r->uv).norm(), (b - l->uv).norm());
    const double dist = std::min(straight, crossed);
    if (best < 0 || dist < best) best = dist;
  }
  return best;
}

std::string NearestAnchor(const Garment& g, const Vec2& uv) {
  std::string best;
  double d = std::numeric_limits<double>::infinity();
  for (const Anchor& a : g.anchors)
    if ((a.uv - uv).norm() < d) d = (a.uv - uv).norm(), best = a.label;
  return best;
}

// ------------------------------------------------------------------ ReleaseModel

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

// ------------------------------------------------------------------ the loop

Json StageTimes::ToJson() const {
  return {{"simulation", simulation},   {"sensing", sensing},           {"fusion", fusion},
          {"recognition", recognition}, {"registration", registration}, {"refinement", refinement}};
}

namespace {

// The recipe's sensing for the test split (what the simulated Kinect is).
SweepOptions TestSensing(const Recipe& r) {
  std::string name;
  for (const auto& s : r.splits)
    if (s.name == "test") name = s.sensing;
  auto it = r.sensing.find(name);
  if (it == r.sensing.end()) it = r.sensing.find("sensed");
  return it == r.sensing.end() ? SweepOptions{} : it->second.sweep;
}

hw::GripperPose SensingPose(double height) {
  hw::GripperPose p;
  p.position = Vec3(0, height, 0);
  return p;
}

hw::GripperPose Home(int arm) {
  hw::GripperPose p;
  p.position = Vec3(arm == 0 ? 0.45 : -0.45, 1.3, 0.35);
  return p;
}

// Appends to a step's note ("; " between notes).
void AddNote(Step& s, const std::string& text) { s.note += (s.note.empty() ? "" : "; ") + text; }

// One IR scan by the free gripper: the jaws (in the grasp pose `pose`) go to jaw(0) along
// a straight path, then to jaw(1), ..., jaw(n - 1) in short moves, one reading at each.
std::vector<double> ScanIr(hw::Arm& arm, hw::RangeSensor& ir, hw::GripperPose pose, int n,
                           const std::function<Vec3(int)>& jaw) {
  std::vector<double> ranges;
  for (int i = 0; i < n; ++i) {
    pose.position = jaw(i);
    arm.Move(i == 0 ? hw::StraightPath(arm.pose(), pose) : hw::Path{{0.016, pose}});
    ranges.push_back(ir.Read());
  }
  return ranges;
}

struct TrialRun {
  const ReleaseModel& model;
  const LoopOptions& o;
  const std::string& category;
  uint64_t seed;
  hw::SimWorld& world;
  TrialResult& res;
  const std::function<void(const std::string&)>& progress;
  int holder = 0;
  std::string trial_category;     // decided by the first recognition (see SenseAndRecognise)
  std::string aimed;              // anchor the holding gripper was sent to ("" before a regrasp)
  bool holder_regrasped = false;  // the holder took its point by an aimed regrasp (not the first grasp)
  // Each hang's category-by-registration scores, in order.
  std::vector<std::map<std::string, double>> fit_scores;

  void Say(const std::string& s) const {
    if (progress) progress(s);
  }

  // Picks the garment up from the table at a seeded random front-layer point.
  void FirstGrasp() {
    const Garment& g = world.garment();
    std::vector<int> front;
    for (int i = 0; i < g.mesh.NumVertices(); ++i)
      if (g.layer.empty() || g.layer[i] == 0) front.push_back(i);
    Rng rng(DeriveSeed(seed, "first_grasp"));
    hw::Arm& a = world.arm(0);
    for (int attempt = 0; attempt < 5; ++attempt) {
      const int v = front[rng.Below(front.size())];
      hw::GripperPose p;
      p.position = world.mesh().V.row(v).transpose();
      a.Move(hw::StraightPath(a.pose(), p));
      if (a.Close().outcome != hw::GraspOutcome::kMiss) break;
      a.Open();
    }
    if (!a.HoldsCloth()) throw Error("first grasp: five attempts missed the garment");
    res.first_grasp_uv = *world.HeldUv(0);
    a.Move(hw::StraightPath(a.pose(), SensingPose(o.sensing_height)));
    holder = 0;
  }

  // The cloth as it hangs now in the holder's object frame, and the holder's pose (the
  // trace's truth, --dump-meshes).
  void RecordCloth(Step& s, const hw::GripperPose& hp) const {
    const Eigen::Matrix3d to_object = Eigen::AngleAxisd(-hp.wrist, Vec3::UnitY()).toRotationMatrix();
    s.cloth = world.mesh();
    for (int i = 0; i < s.cloth.NumVertices(); ++i)
      s.cloth.V.row(i) = (to_object * (Vec3(s.cloth.V.row(i)) - hp.position)).transpose();
    s.holder_position = hp.position;
    s.holder_wrist = hp.wrist;
  }

  // Sweep → fusion → feature → recognition; fills s.frames, s.recon, s.recognition.
  bool SenseAndRecognise(Step& s, int iteration) {
    const Recipe& recipe = model.recipe();
    hw::Arm& h = world.arm(holder);
    auto t0 = Clock::now();
    const Sweep sweep =
        world.camera().CaptureTurning(h, o.capture, DeriveSeed(seed, "sweep/" + std::to_string(iteration)));
    res.times.sensing += Since(t0);
    s.frames = static_cast<int>(sweep.frames.size());
    RecordCloth(s, h.pose());
    t0 = Clock::now();
    FusionOptions fo = recipe.fusion;
    fo.threads = o.fusion_threads;
    const FusionResult fused =
        FuseFrames(sweep.frames, sweep.intrinsics, fo, DeriveSeed(seed, "fusion/" + std::to_string(iteration)));
    if (fused.mesh.NumFaces() == 0) {
      res.failure = "fusion: the reconstruction is empty";
      return false;
    }
    const Tsdf& tsdf = *fused.tsdf;
    const Feature f = ExtractFeature(
        fused.mesh.V, [&tsdf](const Vec3& p) { return tsdf.Sdf(p); }, recipe.feature);
    res.times.fusion += Since(t0);
    s.recon = fused.mesh;
    const rec::Code& code = f;

    t0 = Clock::now();
    rec::RecognizeOptions ro;
    ro.weighted = o.weighted;
    ro.query_height = fused.mesh.V.col(1).maxCoeff() - fused.mesh.V.col(1).minCoeff();  // height gates
    ro.top_k = std::max(ro.top_k, o.plan_prior_top_k);
    // RegistrationCandidates filters them; TrustedAimedEntry looks beyond the top anchors.
    ro.top_entries = model.database().size();
    // Eq. match against every entry once, for the category by registration and the
    // recognition (Recognizer::Recognize is the same Rank of the same matches).
    const rec::Recognizer& recognizer = model.recognizer(o.weighted);
    const rec::PreparedQuery q(code);
    std::vector<rec::Match> matches;
    model.database().matcher().MatchAll(q, &matches);
    // The garment in the gripper does not change between steps: the pose is recognised
    // within the trial's category, which the hangs so far decide.
    const bool refit_changed = UpdateCategoryByFit(s, matches, recognizer, ro);
    ro.category = o.category_known ? category : trial_category;
    s.recognition = recognizer.Rank(q, matches, ro);
    if (!s.category_fit.is_null() && !ro.category.empty()) s.recognition.category_source = "registration";
    s.recognition.match_seconds = Since(t0);
    s.decided_category = s.recognition.category;
    s.category_switched = refit_changed;
    if (s.category_switched) {
      // The aimed anchor was planned on the other category's model: neither kept nor
      // registered as a candidate, and the holder was not placed by an aimed regrasp.
      s.note = "category now " + s.decided_category + " (the fits of " + std::to_string(fit_scores.size()) +
               " hangs): recognition's anchor, not the one aimed at";
      holder_regrasped = false;
    }
    s.recognised_anchor = s.recognition.anchor;
    ApplyPlanPrior(s);
    res.times.recognition += Since(t0);
    s.recognised_right = s.recognition.category == category && s.recognition.anchor == s.held_true_anchor;
    if (trial_category.empty()) trial_category = s.recognition.category;
    return true;
  }

  // One hang tells neighbouring anchors apart poorly (a trouser leg's inner and outer
  // corner hang alike), while the arm knows where it was sent: the aimed anchor, or its
  // twin, is kept, as recognition's top-k anchor when it ranks it among its top k, else
  // as its best-scored entry.
  void ApplyPlanPrior(Step& s) const {
    s.aimed_anchor = aimed;
    if (s.category_switched) return;
    s.prior_rank = PlanPriorRank(s.recognition, aimed, o.plan_prior_top_k);
    if (s.prior_rank >= 0) {
      s.recognition.best = s.recognition.top[s.prior_rank];
    } else {
      const int e = TrustedAimedEntry(s.recognition, aimed);
      if (e < 0) return;
      s.prior_trusted = true;
      s.recognition.best = s.recognition.entries[e];
    }
    s.recognition.anchor = s.recognition.best.anchor;
  }

  // The next anchor by the objective f over the recognised category's desired pairs, from
  // candidate `c`'s anchor on its instance. "" (with `why`) when no anchor is far enough.
  std::string PlanFrom(const rec::Candidate& c, const std::vector<DesiredPair>& pairs, double* f,
                       std::string* why) const {
    const ScoreTable table(model.InstanceAnchors(c.instance), pairs, o.objective);
    const int current = table.IndexOf(c.anchor);
    DRAPE_CHECK(current >= 0, "recognised anchor not among its instance's anchors");
    const ScoreTable::Next next = table.BestNext(current);
    if (next.anchor < 0) {
      *why = "no anchor of " + c.instance + " is far enough from " + c.anchor + " to regrasp";
      return "";
    }
    *f = next.f;
    return table.anchor(next.anchor).label;
  }

  // Score colouring of the registered mesh: each vertex's pattern point is unknown
  // here, so colour by its distance to the desired anchors' registered vertices.
  void ColourByScore(Step& s, const std::vector<DesiredPair>& pairs) const {
    const std::string& instance = s.recognition.best.instance;
    s.point_score.assign(s.registered.NumVertices(), 0.0);
    for (const DesiredPair& d : pairs) {
      for (const std::string& lab : {d.first, d.second}) {
        const int av = model.AnchorVertex(instance, lab);
        if (av < 0 || av >= s.registered.NumVertices()) continue;
        const Vec3 c = s.registered.V.row(av);
        const double sig = 1.0 / (2 * o.objective.sigma_length * o.objective.sigma_length);
        for (int i = 0; i < s.registered.NumVertices(); ++i)
          s.point_score[i] =
              std::max(s.point_score[i], std::exp(-sig * (s.registered.V.row(i).transpose() - c).squaredNorm()));
      }
    }
  }

  // The hang's category by registration ("" when no entry could be registered:
  // recognition's nearest neighbour then decides). Its scores are kept for the sum over
  // the trial's hangs.
  std::string CategoryByFit(Step& s, const std::vector<rec::Match>& matches, const rec::Recognizer& recognizer,
                            const rec::RecognizeOptions& ro) {
    const rec::CategoryFit fit = rec::RecognitionCategoryByFit(
        model.database(), recognizer, ro, matches, s.recon, [this](int e) { return model.HungMesh(e); },
        rec::CategoryFitOptions{});
    s.category_fit = rec::ToJson(fit);
    if (!fit.scores.empty()) fit_scores.push_back(fit.scores);
    return fit.category;
  }

  // The trial's category by registration at every hang, the least score summed over the
  // hangs so far deciding (SummedFitCategory; ties keep it); none with category_known.
  // Returns whether a later hang changed it.
  bool UpdateCategoryByFit(Step& s, const std::vector<rec::Match>& matches, const rec::Recognizer& recognizer,
                           const rec::RecognizeOptions& ro) {
    if (o.category_known) return false;
    const std::string fitted = CategoryByFit(s, matches, recognizer, ro);
    const std::string before = trial_category;
    if (before.empty()) {
      trial_category = fitted;
      return false;
    }
    if (const std::string c = SummedFitCategory(fit_scores, before, o.refit_absent_penalty); !c.empty())
      trial_category = c;
    return trial_category != before;
  }

  // Candidate `c`'s database mesh turned by its recognised rotation.
  TriMesh TurnedSource(const rec::Candidate& c, const rec::Database& db) const {
    return rec::TurnedToQuery(model.HungMesh(c.entry), c.rotation, db.sectors());
  }

  // Candidate registration `reg`'s anchor vertex `v` as the regrasp point: mapped onto the
  // reconstruction (its closest surface point; object frame).
  static Vec3 Predict(const CandidateRegistration& reg, int v, const ExactClosestPoint& onto) {
    return onto.Query(reg.final_mesh().V.row(v).transpose()).point;
  }

  // R + N for the kept candidate only (the others were registered rigidly: the rigid fit
  // selected it and its own point is used). The same registration as R + N for all
  // (Register is deterministic), without the other candidates' non-rigid steps.
  void NonrigidForKept(Step& s, const rec::Database& db, const ExactClosestPoint& onto, CandidateRegistration& reg,
                       const Eigen::Matrix3d& to_world, const Vec3& origin) const {
    const auto tc = Clock::now();
    Step::CandidateTrace& t = s.candidates[s.kept];
    reg = RegisterCandidate(TurnedSource(t.candidate, db), s.recon, onto, true);
    t.note = reg.note;
    t.fit_final = reg.fit_final;
    const int v = model.AnchorVertex(t.candidate.instance, t.next_anchor);
    DRAPE_CHECK(v >= 0 && v < reg.final_mesh().NumVertices(), "the kept candidate has no anchor vertex");
    t.predicted = to_world * Predict(reg, v, onto) + origin;
    t.seconds += Since(tc);
  }

  // Whether the candidate's target anchor (vertex `v` of its registered hang `hang`) or a
  // symmetry twin of it is the hang's lowest point: a twin's registration maps onto the
  // garment's other side, and the plan accepts either (from a crotch or a waist both leg
  // ends hang about as low, and either may be the lowest).
  // Within `radius` horizontally: whether it is the lowest near itself.
  bool TargetIsLowest(const TriMesh& hang, int v, const Step::CandidateTrace& c,
                      double radius = std::numeric_limits<double>::infinity()) const {
    if (AnchorIsLowest(hang, v, o.lowest.tolerance, radius)) return true;
    for (const std::string& twin : rec::SymmetryTwins(c.next_anchor)) {
      const int w = model.AnchorVertex(c.candidate.instance, twin);
      if (w >= 0 && w < hang.NumVertices() && AnchorIsLowest(hang, w, o.lowest.tolerance, radius)) return true;
    }
    return false;
  }

  // The regrasp point from the reconstruction's lowest point (candidates.h LowestPoint): of
  // the whole garment when the kept candidate's registered hang (rigid) has the target or
  // its twin lowest, else the lowest near the registered target when the target or its
  // twin is the lowest near itself (the search is around the target either way: around a
  // registered twin it found waist corners on shorts held by the crotch).
  void PointFromLowest(Step& s, const CandidateRegistration& preg, int v, const Eigen::Matrix3d& to_world,
                       const Vec3& origin) const {
    const double floor = model.recipe().fusion.box.min().y();
    s.lowest_target = TargetIsLowest(preg.reg.rigid, v, s.candidates[s.kept]);
    std::optional<Vec3> p;
    if (s.lowest_target) {
      p = LowestPoint(s.recon, floor, o.lowest);
      if (!p)
        AddNote(s, "lowest point: the reconstruction's lowest point is the region's floor; registered point used");
    } else if (o.lowest.near_radius > 0) {
      s.lowest_near = TargetIsLowest(preg.reg.rigid, v, s.candidates[s.kept], o.lowest.near_radius);
      if (s.lowest_near) p = LowestPoint(s.recon, floor, o.lowest, Vec3(preg.final_mesh().V.row(v).transpose()));
      if (s.lowest_near && !p)
        AddNote(s, "lowest point near the target: none above the region's floor; registered point used");
    }
    if (!p) return;
    s.predicted = to_world * *p + origin;
    s.lowest_taken = true;
  }

  // The regrasp point from the free end hanging below the target (candidates.h HangingEnd):
  // the reconstruction's lowest point near the registered end, raised by the distance of
  // target and end on the candidate instance's pattern. Only where the database hang (rigid
  // registration) has the end below the target, as a free end hangs.
  void PointFromHangingEnd(Step& s, const CandidateRegistration& reg, const Step::CandidateTrace& c,
                           const Eigen::Matrix3d& to_world, const Vec3& origin) const {
    const std::string end = HangingEnd(c.next_anchor);
    if (end.empty()) return;
    const int v = model.AnchorVertex(c.candidate.instance, c.next_anchor);
    const int e = model.AnchorVertex(c.candidate.instance, end);
    const TriMesh& rigid = reg.reg.rigid;
    if (v < 0 || e < 0 || v >= rigid.NumVertices() || e >= rigid.NumVertices()) return;
    const std::optional<Vec2> uv_anchor = model.AnchorUv(c.candidate.instance, c.next_anchor);
    const std::optional<Vec2> uv_end = model.AnchorUv(c.candidate.instance, end);
    if (!uv_anchor || !uv_end) return;
    const double length = (*uv_anchor - *uv_end).norm();
    if (rigid.V(v, 1) - rigid.V(e, 1) < o.hanging.min_drop * length) return;  // the end is not below
    s.hanging_end = end;
    s.hanging_length = length;
    const Vec3 around = reg.final_mesh().V.row(e).transpose();
    const auto low = LowestNear(s.recon, around, model.recipe().fusion.box.min().y(), o.hanging);
    if (!low) {
      AddNote(s, "hanging end: no reconstruction above the region's floor near the registered " + end +
                     "; registered point used");
      return;
    }
    s.predicted = to_world * (*low + Vec3(0, length, 0)) + origin;
    s.hanging_taken = true;
  }

  // The regrasp point from the kept candidate's registration `preg` (its target at vertex
  // `v`): the registered target mapped onto the reconstruction, or the reconstruction's
  // lowest point, or the hanging end's; the ladder's first rungs.
  void PointFromKept(Step& s, const CandidateRegistration& preg, int v, const Eigen::Matrix3d& to_world,
                     const Vec3& origin) const {
    s.predicted = s.candidates[s.kept].predicted;
    s.ladder.rigid = to_world * preg.reg.rigid.V.row(v).transpose() + origin;
    s.ladder.nonrigid = to_world * preg.final_mesh().V.row(v).transpose() + origin;
    // The turn is about the vertical: "below" is the same in the object frame.
    PointFromLowest(s, preg, v, to_world, origin);
    if (!s.lowest_taken) PointFromHangingEnd(s, preg, s.candidates[s.kept], to_world, origin);
  }

  // Registration of each candidate's database mesh (turned by its recognised rotation)
  // onto the reconstruction, its plan and its next anchor mapped onto the reconstruction;
  // the best fit is kept (candidates.h) and the regrasp point predicted in the world frame.
  bool PlanRegisterAndPredict(Step& s, const rec::Database& db, const std::vector<DesiredPair>& pairs) {
    const auto t0 = Clock::now();
    const std::vector<rec::Candidate> cands = RegistrationCandidates(
        s.recognition, s.prior_rank >= 0 || s.prior_trusted, s.category_switched ? "" : s.aimed_anchor, o.candidates);
    s.recognition.entries.clear();  // the trace lists the candidates
    const ExactClosestPoint onto(s.recon);
    const hw::GripperPose hp = world.arm(holder).pose();
    const Eigen::Matrix3d to_world = Eigen::AngleAxisd(hp.wrist, Vec3::UnitY()).toRotationMatrix();
    std::vector<CandidateRegistration> regs(cands.size());
    std::vector<int> vertex(cands.size(), -1);
    std::vector<double> fits(cands.size(), -1);
    std::string first_failure;
    // The rigid fit selects and the kept candidate's point is used: only it needs R + N.
    const bool nonrigid_kept_only = o.nonrigid && cands.size() > 1;
    for (size_t i = 0; i < cands.size(); ++i) {
      const auto tc = Clock::now();
      Step::CandidateTrace t;
      t.candidate = cands[i];
      t.right = cands[i].category == category && cands[i].anchor == s.held_true_anchor;
      const std::vector<std::string> twins = rec::SymmetryTwins(s.held_true_anchor);
      t.twin = cands[i].category == category && std::find(twins.begin(), twins.end(), cands[i].anchor) != twins.end();
      if (t.right && s.true_rank < 0) s.true_rank = static_cast<int>(i);
      std::string why;
      t.next_anchor = PlanFrom(cands[i], pairs, &t.f, &why);
      if (t.next_anchor.empty()) {
        t.note = why;
        if (first_failure.empty()) first_failure = why;
        s.candidates.push_back(std::move(t));
        continue;
      }
      regs[i] = RegisterCandidate(TurnedSource(cands[i], db), s.recon, onto, o.nonrigid && !nonrigid_kept_only);
      t.note = regs[i].note;
      t.icp_rms = regs[i].reg.report.icp.rms_after;
      t.fit_rigid = regs[i].fit_rigid;
      t.fit_final = nonrigid_kept_only ? -1 : regs[i].fit_final;
      const int v = model.AnchorVertex(cands[i].instance, t.next_anchor);
      if (v < 0 || v >= regs[i].final_mesh().NumVertices()) {
        t.note = "the database has no vertex for anchor " + t.next_anchor + " of " + cands[i].instance;
        if (first_failure.empty()) first_failure = t.note;
      } else {
        vertex[i] = v;
        t.usable = true;
        fits[i] = t.fit_rigid;
        t.predicted = to_world * Predict(regs[i], v, onto) + hp.position;
      }
      t.seconds = Since(tc);
      s.candidates.push_back(std::move(t));
    }
    s.kept = KeepCandidate(fits);
    if (s.kept >= 0 && nonrigid_kept_only) NonrigidForKept(s, db, onto, regs[s.kept], to_world, hp.position);
    res.times.registration += Since(t0);
    if (s.kept < 0) {
      res.failure = first_failure;
      return false;
    }
    const Step::CandidateTrace& k = s.candidates[s.kept];
    const CandidateRegistration& reg = regs[s.kept];
    s.kept_right = k.right;
    s.recognition.best = k.candidate;
    s.recognition.anchor = k.candidate.anchor;
    s.current_anchor = k.candidate.anchor;
    s.next_anchor = k.next_anchor;
    s.f = k.f;
    s.registered = reg.final_mesh();
    s.icp_rms = k.icp_rms;
    if (!reg.note.empty()) s.note = reg.note;
    ColourByScore(s, pairs);
    PointFromKept(s, reg, vertex[s.kept], to_world, hp.position);
    return true;
  }

  // Sweep → fusion → feature → recognition → candidates: plan + registration; fills `s`.
  // Returns false (with res.failure) when no plan can be made.
  bool SenseAndPlan(Step& s, int iteration, const rec::Database& db) {
    if (!SenseAndRecognise(s, iteration)) return false;
    const std::vector<DesiredPair> pairs = DesiredPairsFor(s.recognition.category);
    if (pairs.empty()) {
      res.failure = "recognised as '" + s.recognition.category + "', which has no desired anchor pair";
      return false;
    }
    return PlanRegisterAndPredict(s, db, pairs);
  }

  // Evaluation only: how far the predicted and grasp points are from the real garment's
  // next anchor (or its twin, whichever is nearer the prediction) as it hangs now.
  void MeasureAgainstTruth(Step& s) const {
    const Garment& g = world.garment();
    // Each candidate's prediction against its own next anchor (or a twin, nearer).
    for (Step::CandidateTrace& t : s.candidates) {
      if (!t.usable) continue;
      std::vector<std::string> ls = rec::SymmetryTwins(t.next_anchor);
      ls.insert(ls.begin(), t.next_anchor);
      for (const std::string& l : ls) {
        const Anchor* a = g.FindAnchor(l);
        if (!a || a->vertex < 0 || a->vertex >= world.mesh().NumVertices()) continue;
        const double d = (t.predicted - Vec3(world.mesh().V.row(a->vertex))).norm();
        if (t.predicted_error < 0 || d < t.predicted_error) t.predicted_error = d;
      }
    }
    std::vector<std::string> labels = rec::SymmetryTwins(s.next_anchor);
    labels.insert(labels.begin(), s.next_anchor);
    double best = std::numeric_limits<double>::infinity();
    Vec3 target = Vec3::Zero();
    for (const std::string& l : labels) {
      const Anchor* a = g.FindAnchor(l);
      if (!a || a->vertex < 0 || a->vertex >= world.mesh().NumVertices()) continue;
      const Vec3 p = world.mesh().V.row(a->vertex);
      if ((s.predicted - p).norm() < best) {
        best = (s.predicted - p).norm();
        s.target_true_anchor = l;
        s.predicted_error = best;
        s.grasp_error = (s.grasp - p).norm();
        target = p;
      }
    }
    if (s.target_true_anchor.empty()) return;
    Step::Ladder& L = s.ladder;
    L.rigid_error = (L.rigid - target).norm();
    L.nonrigid_error = (L.nonrigid - target).norm();
    L.mapped_error = s.predicted_error;
    L.refined_error = s.grasp_error;
    const Vec3 c = Vec3::UnitY().cross(s.approach).normalized();
    auto frame = [&](const Vec3& d) { return Vec3(d.dot(c), d.y(), d.dot(s.approach)); };
    L.mapped_offset = frame(s.predicted - target);
    L.refined_offset = frame(s.grasp - target);
    // What the jaws would take at the registered point without IR refinement.
    hw::GripperPose at;
    at.approach = s.approach;
    at.closing = c;
    at.position = s.predicted + s.approach * o.grasp_depth;
    const hw::GraspProbe p = world.ProbeGrasp(at);
    L.no_ir_outcome = hw::GraspOutcomeName(p.report.outcome);
    const Anchor* ta = g.FindAnchor(s.target_true_anchor);
    if (p.uv) {
      L.no_ir_pinch_error = (p.pinch - target).norm();
      if (ta) L.no_ir_pattern_error = (*p.uv - ta->uv).norm();
    }
  }

  // Evaluation only: rung (e) of the ladder, where the jaws at `g` close (probed just
  // before they do).
  void MeasureClosing(Step& s, const hw::GripperPose& g) const {
    if (s.target_true_anchor.empty()) return;
    const Anchor* a = world.garment().FindAnchor(s.target_true_anchor);
    if (!a || a->vertex < 0 || a->vertex >= world.mesh().NumVertices()) return;
    const Vec3 target = world.mesh().V.row(a->vertex);
    const hw::GraspProbe p = world.ProbeGrasp(g);
    if (!p.uv) return;
    s.ladder.closed = p.centroid;
    s.ladder.pinch = p.pinch;
    s.ladder.closed_error = (p.centroid - target).norm();
    s.ladder.pinch_error = (p.pinch - target).norm();
  }

  // IR scan across the predicted point with the free gripper; returns the grasp pose.
  hw::GripperPose Refine(Step& s, int free_arm) {
    const auto t0 = Clock::now();
    const Vec3 axis = world.arm(holder).pose().position;
    Vec3 radial(s.predicted.x() - axis.x(), 0, s.predicted.z() - axis.z());
    if (radial.norm() < 0.02) radial = Vec3(0, 0, 1);  // on the axis: come from the camera's side
    const Vec3 a = -radial.normalized();
    const Vec3 c = Vec3::UnitY().cross(a).normalized();
    s.approach = a;
    hw::GripperPose g;
    g.approach = a;
    g.closing = c;
    g.position = s.predicted + a * o.grasp_depth;
    if (o.ir_refinement) {
      hw::Arm& arm = world.arm(free_arm);
      hw::RangeSensor& ir = world.ir(free_arm);
      IrScanPlan plan;
      plan.predicted = s.predicted;
      plan.approach = a;
      plan.closing = c;
      plan.mount = ir.mount();
      plan.standoff = o.standoff;
      plan.grasp_depth = o.grasp_depth;
      const int half = o.refine.half_width_samples;
      s.ir_ranges = ScanIr(arm, ir, g, 2 * half + 1,
                           [&](int i) { return plan.JawDuringScan((i - half) * o.refine.sample_spacing); });
      RefineOptions ro = o.refine;
      if (s.lowest_taken || s.hanging_taken) ro.search_half_width_samples = 0;  // an observed point: depth only
      if (s.hanging_taken) {
        ro.depth_half_width_samples =
            std::min(ro.half_width_samples, static_cast<int>(std::lround(o.hanging.depth_window / ro.sample_spacing)));
      }
      s.refine = RefineScan(s.ir_ranges, ro);
      if (s.refine.valid) {
        g.position = plan.Grasp(s.refine);
      } else {
        AddNote(s, "no IR reading in the whole scan: registered point used");
      }
    }
    res.times.refinement += Since(t0);
    s.grasp = g.position;
    return g;
  }

  void Run() {
    const rec::Database& db = model.database();
    FirstGrasp();
    for (int it = 0; it < o.max_regrasps; ++it) {
      Step s;
      s.held_uv = *world.HeldUv(holder);
      s.held_true_anchor = NearestAnchor(world.garment(), s.held_uv);
      Say("step " + std::to_string(it + 1) + ": sensing");
      const bool planned = SenseAndPlan(s, it, db);
      if (!planned) {
        res.steps.push_back(std::move(s));
        return;
      }
      Say("step " + std::to_string(it + 1) + ": " + s.current_anchor + " → " + s.next_anchor);
      const int free_arm = 1 - holder;
      hw::Arm& fa = world.arm(free_arm);
      const hw::GripperPose g = Refine(s, free_arm);
      MeasureAgainstTruth(s);
      fa.Move(hw::StraightPath(fa.pose(), g));
      MeasureClosing(s, g);
      s.regrasp = fa.Close();
      ++res.regrasps;
      if (s.regrasp.outcome == hw::GraspOutcome::kMiss) {
        aimed = s.current_anchor;  // the holder still holds what this step took it for
        fa.Open();
        fa.Move(hw::StraightPath(fa.pose(), Home(free_arm)));
        res.steps.push_back(std::move(s));
        continue;
      }
      s.regrasp_uv = world.HeldUv(free_arm);
      s.regrasp_true_anchor = NearestAnchor(world.garment(), *s.regrasp_uv);
      if (const Anchor* t = world.garment().FindAnchor(s.target_true_anchor))
        s.regrasp_pattern_error = (*s.regrasp_uv - t->uv).norm();
      s.holder_regrasped = holder_regrasped;
      if (MayStop(o, s.f, holder_regrasped)) {
        res.converged = true;
        res.final_f = s.f;
        res.steps.push_back(std::move(s));
        return;
      }
      if (s.f >= o.objective.xi)  // held back: the holder is the random first grasp
        AddNote(s, "f >= xi on the first grasp, known from recognition alone: the holder lets go");
      // Not there yet: the old grasp lets go, the garment hangs from the new one.
      world.arm(holder).Open();
      s.released_other = true;
      world.arm(holder).Move(hw::StraightPath(world.arm(holder).pose(), Home(holder)));
      fa.Move(hw::StraightPath(fa.pose(), SensingPose(o.sensing_height)));
      aimed = s.next_anchor;
      res.steps.push_back(std::move(s));
      holder = free_arm;
      holder_regrasped = true;
      if (world.state() == hw::ClothState::kLost) {
        res.failure = "the garment was lost";
        return;
      }
    }
    res.failure = "no desired pair after " + std::to_string(o.max_regrasps) + " regrasps";
  }
};

}  // namespace

TrialResult RunTrial(const ReleaseModel& model, const std::string& category, const LoopOptions& options, uint64_t seed,
                     const std::function<void(const std::string&)>& progress) {
  options.Validate();
  const auto t_start = Clock::now();
  if (DesiredPairsFor(category).empty())
    throw Error("unfold: category '" + category +
                "' has no desired anchor pair (long_sleeve_shirt, pants, shorts, towel have)");
  if (!model.database().HasCategory(category))
    throw Error("unfold: the release's database has no '" + category + "' garments");
  const auto& tg = model.TestInstance(category);
  hw::SimOptions so;
  so.hang = tg.hang;
  so.camera = TestSensing(model.recipe());
  LoopOptions o = options;  // the garment turns where the release's sweeps held it
  if (o.sensing_height == 0) o.sensing_height = so.camera.gripper_height;
  TrialResult res;
  res.category = category;
  res.instance = tg.instance;
  res.seed = seed;
  res.sensing_height = o.sensing_height;
  for (const Anchor& a : tg.garment.anchors) res.true_anchors.push_back({a.label, a.uv});
  hw::SimWorld world(tg.garment, tg.material, tg.fit, so, DeriveSeed(seed, "world"));
  TrialRun run{model, o, category, seed, world, res, progress, 0, "", "", false, {}};
  try {
    run.Run();
  } catch (const NumericalError& e) {
    res.failure = std::string("simulation: ") + e.what();
  }
  bool all_held = res.regrasps > 0;
  for (const Step& s : res.steps)
    if (s.regrasp.outcome == hw::GraspOutcome::kMiss && !s.current_anchor.empty()) all_held = false;
  res.regrasp_success = all_held;
  res.recognition_success = !res.steps.empty() && res.steps.front().recognised_right;
  for (int k = 0; k < 2; ++k)
    if (auto uv = world.HeldUv(k)) res.final_uv.push_back(*uv);
  if (res.final_uv.size() == 2)
    res.final_pair_distance =
        DesiredPairDistance(world.garment(), DesiredPairsFor(category), res.final_uv[0], res.final_uv[1]);
  res.unfolded = res.converged && res.final_pair_distance >= 0 && res.final_pair_distance <= options.success_distance;
  if (res.converged && options.place_flat && world.state() == hw::ClothState::kHeldByTwo) {
    if (progress) progress("placing flat");
    try {
      const hw::PlaceFlatReport pr = world.PlaceFlat(options.place);
      res.placed = pr.ok;
      res.place_failure = pr.failure;
      if (pr.ok) res.coverage = Coverage(world.mesh(), world.garment());
    } catch (const NumericalError& e) {
      res.place_failure = e.what();
    }
  }
  res.times.simulation = world.simulation_seconds();
  res.hangs = world.hangs(), res.fallbacks = world.fallbacks(), res.unsettled = world.unsettled();
  res.retries = world.retries();
  res.fall_cost = world.fall_cost();
  res.final_state = hw::ClothStateName(world.state());
  res.final_mesh = world.mesh();
  res.seconds = Since(t_start);
  return res;
}

namespace {
// The regrasp point's error ladder of a step (Step::Ladder), for its trace.
Json LadderJson(const Step::Ladder& l) {
  return {{"rigid", J(l.rigid)},
          {"nonrigid", J(l.nonrigid)},
          {"closed", J(l.closed)},
          {"pinch", J(l.pinch)},
          {"a_rigid_error_m", l.rigid_error},
          {"b_nonrigid_error_m", l.nonrigid_error},
          {"c_mapped_error_m", l.mapped_error},
          {"d_refined_error_m", l.refined_error},
          {"e_closed_error_m", l.closed_error},
          {"e_pinch_error_m", l.pinch_error},
          {"mapped_offset_m", J(l.mapped_offset)},
          {"refined_offset_m", J(l.refined_offset)},
          {"no_ir_outcome", l.no_ir_outcome},
          {"no_ir_pinch_error_m", l.no_ir_pinch_error},
          {"no_ir_pattern_error_m", l.no_ir_pattern_error}};
}

// The registration candidates of a step, the one kept and its truth, into its trace `j`.
void AddCandidates(const Step& s, Json& j) {
  Json cands = Json::array();
  for (const Step::CandidateTrace& t : s.candidates) {
    const rec::Candidate& c = t.candidate;
    cands.push_back({{"entry", c.id},
                     {"instance", c.instance},
                     {"anchor", c.anchor},
                     {"rotation", c.rotation},
                     {"score", c.score},
                     {"usable", t.usable},
                     {"next_anchor", t.next_anchor},
                     {"f", t.f},
                     {"fit_rigid_m", t.fit_rigid},
                     {"fit_final_m", t.fit_final},
                     {"icp_rms", t.icp_rms},
                     {"predicted", J(t.predicted)},
                     {"note", t.note},
                     {"seconds", t.seconds},
                     {"truth", {{"right", t.right}, {"twin", t.twin}, {"predicted_error_m", t.predicted_error}}}});
  }
  j["candidates"] = std::move(cands);
  j["kept_candidate"] = s.kept;
  j["truth"]["kept_right"] = s.kept_right;
  j["truth"]["true_rank"] = s.true_rank;
}

// IR readings; no reading (nothing in range) → null.
Json RangesJson(const std::vector<double>& ranges) {
  Json r = Json::array();
  for (double x : ranges) r.push_back(std::isfinite(x) ? Json(x) : Json(nullptr));
  return r;
}

Json StepJson(const Step& s) {
  Json j{{"held_uv", J(s.held_uv)},
         {"held_true_anchor", s.held_true_anchor},
         {"frames", s.frames},
         {"recon_vertices", s.recon.NumVertices()},
         {"holder", {{"position", J(s.holder_position)}, {"wrist", s.holder_wrist}}},
         {"recognition", rec::ToJson(s.recognition)},
         {"recognised_right", s.recognised_right},
         {"category",
          {{"decided", s.decided_category}, {"switched", s.category_switched}, {"registration", s.category_fit}}},
         {"aimed_anchor", s.aimed_anchor},
         {"recognised_anchor", s.recognised_anchor},
         {"prior_rank", s.prior_rank},
         {"prior_trusted", s.prior_trusted},
         {"holder_regrasped", s.holder_regrasped},
         {"icp_rms", s.icp_rms},
         {"current_anchor", s.current_anchor},
         {"next_anchor", s.next_anchor},
         {"f", s.f},
         {"predicted", J(s.predicted)},
         {"grasp", J(s.grasp)},
         {"approach", J(s.approach)},
         {"ir_ranges", RangesJson(s.ir_ranges)},
         {"ir_response", s.refine.response},
         {"ir_best_offset", s.refine.offset},
         {"ir_fold_found", s.refine.fold_found},
         {"lowest_point", {{"target", s.lowest_target}, {"near", s.lowest_near}, {"taken", s.lowest_taken}}},
         {"hanging_end", {{"end", s.hanging_end}, {"taken", s.hanging_taken}, {"length_m", s.hanging_length}}},
         {"regrasp",
          {{"outcome", hw::GraspOutcomeName(s.regrasp.outcome)},
           {"captured", s.regrasp.captured},
           {"note", s.regrasp.note}}},
         {"regrasp_uv", s.regrasp_uv ? J(*s.regrasp_uv) : Json(nullptr)},
         {"regrasp_true_anchor", s.regrasp_true_anchor},
         {"released_other", s.released_other},
         {"truth",
          {{"target_anchor", s.target_true_anchor},
           {"predicted_error_m", s.predicted_error},
           {"grasp_error_m", s.grasp_error},
           {"regrasp_pattern_error_m", s.regrasp_pattern_error},
           {"ladder", LadderJson(s.ladder)}}},
         {"note", s.note}};
  AddCandidates(s, j);
  return j;
}
}  // namespace

Json TrialResult::ToJson() const {
  Json steps_j = Json::array();
  for (const Step& s : steps) steps_j.push_back(StepJson(s));
  Json fu = Json::array();
  for (const Vec2& u : final_uv) fu.push_back(J(u));
  Json anchors = Json::object();
  for (const AnchorPoint& a : true_anchors) anchors[a.label] = J(a.uv);
  return {{"category", category},
          {"instance", instance},
          {"seed", seed},
          {"sensing_height", sensing_height},
          {"first_grasp_uv", J(first_grasp_uv)},
          {"steps", steps_j},
          {"regrasps", regrasps},
          {"recognition_success", recognition_success},
          {"regrasp_success", regrasp_success},
          {"converged", converged},
          {"unfolded", unfolded},
          {"final_f", final_f},
          {"final_uv", fu},
          {"final_pair_distance", final_pair_distance >= 0 ? Json(final_pair_distance) : Json(nullptr)},
          {"truth", {{"anchors_uv", anchors}}},
          {"final_state", final_state},
          {"placed", placed},
          {"place_failure", place_failure},
          {"coverage", placed ? Json(coverage) : Json(nullptr)},
          {"failure", failure},
          {"simulation",
           {{"hangs", hangs},
            {"fallbacks", fallbacks},
            {"unsettled", unsettled},
            {"retries", retries},
            {"falls", fall_cost.falls},
            {"fall_steps", fall_cost.steps},
            {"fall_fail_safe_steps", fall_cost.fail_safe_steps},
            {"fall_zone_rounds", fall_cost.zone_rounds},
            {"fall_ccd_tests", fall_cost.ccd_tests},
            {"max_fall_ccd_tests", fall_cost.max_ccd_tests}}},
          {"timing", times.ToJson()},
          {"seconds", seconds}};
}

}  // namespace drape::unfolding
