// The regrasping loop (loop.h): a trial's phases in turn (trial.h), then the verdict by
// truth and the placing on the table.
#include "runtime/unfolding/loop.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.h"
#include "common/field_error.h"
#include "common/rng.h"
#include "common/timing.h"
#include "runtime/tabletop/table.h"
#include "runtime/unfolding/trial.h"

namespace drape::unfolding {

namespace hw = drape::hardware;

void LoopOptions::Validate() const {
  observe.Validate();
  recognise.Validate();
  plan.Validate();
  regrasp.Validate();
  place.Validate();
  if (max_regrasps < 1 || max_regrasps > 100) BadField(max_regrasps, "LoopOptions.max_regrasps", "must be in 1..100");
  if (!(success_distance > 0)) BadField(success_distance, "LoopOptions.success_distance", "must be > 0 m");
}

Json StageTimes::ToJson() const {
  return {{"simulation", simulation},   {"sensing", sensing},           {"fusion", fusion},
          {"recognition", recognition}, {"registration", registration}, {"refinement", refinement}};
}

double Coverage(const TriMesh& lying, const Garment& garment, double mpp) {
  TriMesh flat;
  flat.F = garment.mesh.F;
  flat.V = tabletop::LayFlat(garment.mesh, tabletop::TableOptions{});
  auto area = [mpp](const TriMesh& m) {
    const cv::Mat mask = tabletop::TopDownMask(m, tabletop::FrameCamera(m.V, mpp));
    return double(cv::countNonZero(mask));
  };
  const double a = area(flat);
  DRAPE_CHECK(a > 0, "the flat garment has no top-down area");
  return area(lying) / a;
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

void AddNote(Step& s, const std::string& text) { s.note += (s.note.empty() ? "" : "; ") + text; }

Trial::Trial(const ReleaseModel& model, const std::string& category, const LoopOptions& o, uint64_t seed,
             hw::SimWorld& world, TrialResult& res, const Progress& progress)
    : model_(model), category_(category), o_(o), seed_(seed), world_(world), res_(res), progress_(progress) {}

void Trial::Say(const std::string& s) const {
  if (progress_) progress_(s);
}

void Trial::Run() {
  PickUp();
  for (int it = 0; it < o_.max_regrasps; ++it) {
    Step s;
    s.truth.held_uv = *world_.HeldUv(holder_);
    s.truth.held_anchor = NearestAnchor(world_.garment(), s.truth.held_uv);
    Say("step " + std::to_string(it + 1) + ": sensing");
    Feature code;
    bool planned = Observe(s, it, &code);
    if (planned) {
      Recognise(s, code);
      planned = Plan(s);
    }
    if (!planned) {
      res_.steps.push_back(std::move(s));
      return;
    }
    Say("step " + std::to_string(it + 1) + ": " + s.plan.current_anchor + " → " + s.plan.next_anchor);
    const int free_arm = 1 - holder_;
    if (!Regrasp(s, free_arm)) {
      aimed_ = s.plan.current_anchor;  // the holder still holds what this step took it for
      res_.steps.push_back(std::move(s));
      continue;
    }
    if (MayStop(o_.plan.objective, s.plan.f, holder_regrasped_)) {
      if (Verify(s, it)) {
        res_.converged = true;
        res_.final_f = s.plan.f;
        res_.steps.push_back(std::move(s));
        return;
      }
      AddNote(s, "f >= xi on the belief, not verified (" + s.verify.why + "): the holder lets go");
    } else if (s.plan.f >= o_.plan.objective.xi) {  // held back: the holder is the random first grasp
      AddNote(s, "f >= xi on the first grasp, known from recognition alone: the holder lets go");
    }
    LetGo(s, free_arm);
    aimed_ = s.plan.next_anchor;
    res_.steps.push_back(std::move(s));
    if (world_.state() == hw::ClothState::kLost) {
      res_.failure = "the garment was lost";
      return;
    }
  }
  res_.failure = "no desired pair after " + std::to_string(o_.max_regrasps) + " regrasps";
}

std::string UnsupportedBelief(const Recognised& r, int top_k) {
  if (r.prior_trusted)
    return "its own hang does not rank the held anchor " + r.recognition.anchor + " (or a twin) in its top " +
           std::to_string(top_k) + " (recognition: " + r.recognised_anchor + ")";
  if (r.category_fit.is_object() && r.category_fit.contains("category")) {
    const std::string hang_category = r.category_fit["category"].get<std::string>();
    if (!hang_category.empty() && hang_category != r.category)
      return "its own hang fits " + hang_category + " best by registration, the plan stands on " + r.category;
  }
  return "";
}

// Plan on the belief, declare on evidence: the plan prior keeps the anchor the holder was
// sent to even when its own hang ranks it nowhere near (TrustedAimedEntry), and the
// trial's category sums every hang. On paper 2.3.0 (30 trials, seed 1) 6 of 30 declared
// successes had not unfolded: 4 stood on an aimed anchor recognition did not rank in its
// top k, 1 on a category the last hang's registration fitted worse than another.
bool Trial::Verify(Step& s, int step) {
  Verified& v = s.verify;
  v.checked = true;
  std::vector<Vec2> held;  // truth, for the belief-only count
  for (int k = 0; k < 2; ++k)
    if (auto uv = world_.HeldUv(k)) held.push_back(*uv);
  if (held.size() == 2)
    v.pair_distance = DesiredPairDistance(world_.garment(), DesiredPairsFor(category_), held[0], held[1]);
  if (res_.belief_step < 0)
    res_.belief_step = step, res_.belief_regrasps = res_.regrasps, res_.belief_pair_distance = v.pair_distance;
  if (!o_.verify) return v.passed = true;
  v.why = UnsupportedBelief(s.recognise, o_.recognise.plan_prior_top_k);
  v.passed = v.why.empty();
  if (!v.passed) ++res_.rejected;
  return v.passed;
}

namespace {
// The verdict by truth once the loop has stopped: the regrasps, the first recognition,
// where both grippers hold and how far that is from a desired pair.
void JudgeTrial(TrialResult& res, const hw::SimWorld& world, const std::string& category, double success_distance) {
  bool all_held = res.regrasps > 0;
  for (const Step& s : res.steps)
    if (s.regrasp.report.outcome == hw::GraspOutcome::kMiss && !s.plan.current_anchor.empty()) all_held = false;
  res.regrasp_success = all_held;
  res.recognition_success = !res.steps.empty() && res.steps.front().truth.recognised_right;
  for (int k = 0; k < 2; ++k)
    if (auto uv = world.HeldUv(k)) res.final_uv.push_back(*uv);
  if (res.final_uv.size() == 2)
    res.final_pair_distance =
        DesiredPairDistance(world.garment(), DesiredPairsFor(category), res.final_uv[0], res.final_uv[1]);
  res.unfolded = res.converged && res.final_pair_distance >= 0 && res.final_pair_distance <= success_distance;
  res.belief_unfolded =
      res.belief_step >= 0 && res.belief_pair_distance >= 0 && res.belief_pair_distance <= success_distance;
}

// Both grippers hold at f ≥ ξ: lay the garment on the table, and its coverage.
void PlaceFlat(TrialResult& res, hw::SimWorld& world, const hw::PlaceFlatOptions& options,
               const std::function<void(const std::string&)>& progress) {
  if (progress) progress("placing flat");
  try {
    const hw::PlaceFlatReport pr = world.PlaceFlat(options);
    res.placed = pr.ok;
    res.place_failure = pr.failure;
    if (pr.ok) res.coverage = Coverage(world.mesh(), world.garment());
  } catch (const NumericalError& e) {
    res.place_failure = e.what();
  }
}
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
  so.camera = model.TestSensing();
  LoopOptions o = options;  // the garment turns where the release's sweeps held it
  if (o.observe.sensing_height == 0) o.observe.sensing_height = so.camera.gripper_height;
  TrialResult res;
  res.category = category;
  res.instance = tg.instance;
  res.seed = seed;
  res.sensing_height = o.observe.sensing_height;
  for (const Anchor& a : tg.garment.anchors) res.true_anchors.push_back({a.label, a.uv});
  hw::SimWorld world(tg.garment, tg.material, tg.fit, so, DeriveSeed(seed, "world"));
  try {
    Trial(model, category, o, seed, world, res, progress).Run();
  } catch (const NumericalError& e) {
    res.failure = std::string("simulation: ") + e.what();
  }
  JudgeTrial(res, world, category, options.success_distance);
  if (res.converged && options.place_flat && world.state() == hw::ClothState::kHeldByTwo)
    PlaceFlat(res, world, options.place, progress);
  res.times.simulation = world.simulation_seconds();
  res.hangs = world.hangs(), res.fallbacks = world.fallbacks(), res.unsettled = world.unsettled();
  res.retries = world.retries();
  res.fall_cost = world.fall_cost();
  res.final_state = hw::ClothStateName(world.state());
  res.final_mesh = world.mesh();
  res.seconds = Since(t_start);
  return res;
}

}  // namespace drape::unfolding
