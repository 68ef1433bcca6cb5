// A trial's trace (loop.h TrialResult::ToJson): every step's decisions and, from the
// simulated garment, their truth; no meshes.
#include <cmath>

#include "runtime/recognition/evaluate.h"
#include "runtime/unfolding/loop.h"

namespace drape::unfolding {

namespace rec = drape::recognition;
namespace hw = drape::hardware;

namespace {
Json J(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }
Json J(const Vec2& v) { return Json::array({v.x(), v.y()}); }

// The regrasp point's error ladder of a step (StepTruth::Ladder), for its trace.
Json LadderJson(const StepTruth::Ladder& l) {
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
  for (const CandidateTrace& t : s.plan.candidates) {
    const rec::Candidate& c = t.candidate;
    cands.push_back(
        {{"entry", c.id},
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
         {"truth",
          {{"right", t.truth.right}, {"twin", t.truth.twin}, {"predicted_error_m", t.truth.predicted_error}}}});
  }
  j["candidates"] = std::move(cands);
  j["kept_candidate"] = s.plan.kept;
  j["truth"]["kept_right"] = s.truth.kept_right;
  j["truth"]["true_rank"] = s.truth.true_rank;
}

// IR readings; no reading (nothing in range) → null.
Json RangesJson(const std::vector<double>& ranges) {
  Json r = Json::array();
  for (double x : ranges) r.push_back(std::isfinite(x) ? Json(x) : Json(nullptr));
  return r;
}

Json StepJson(const Step& s) {
  Json j{{"held_uv", J(s.truth.held_uv)},
         {"held_true_anchor", s.truth.held_anchor},
         {"frames", s.observe.frames},
         {"recon_vertices", s.observe.recon.NumVertices()},
         {"holder", {{"position", J(s.truth.holder_position)}, {"wrist", s.truth.holder_wrist}}},
         {"recognition", rec::ToJson(s.recognise.recognition)},
         {"recognised_right", s.truth.recognised_right},
         {"category",
          {{"decided", s.recognise.category},
           {"switched", s.recognise.category_switched},
           {"registration", s.recognise.category_fit}}},
         {"aimed_anchor", s.recognise.aimed_anchor},
         {"recognised_anchor", s.recognise.recognised_anchor},
         {"prior_rank", s.recognise.prior_rank},
         {"prior_trusted", s.recognise.prior_trusted},
         {"holder_regrasped", s.regrasp.holder_regrasped},
         {"icp_rms", s.plan.icp_rms},
         {"current_anchor", s.plan.current_anchor},
         {"next_anchor", s.plan.next_anchor},
         {"f", s.plan.f},
         {"predicted", J(s.plan.predicted)},
         {"grasp", J(s.regrasp.grasp)},
         {"approach", J(s.regrasp.approach)},
         {"ir_ranges", RangesJson(s.regrasp.ir_ranges)},
         {"ir_response", s.regrasp.refine.response},
         {"ir_best_offset", s.regrasp.refine.offset},
         {"ir_fold_found", s.regrasp.refine.fold_found},
         {"lowest_point",
          {{"target", s.plan.lowest_target}, {"near", s.plan.lowest_near}, {"taken", s.plan.lowest_taken}}},
         {"hanging_end",
          {{"end", s.plan.hanging_end}, {"taken", s.plan.hanging_taken}, {"length_m", s.plan.hanging_length}}},
         {"regrasp",
          {{"outcome", hw::GraspOutcomeName(s.regrasp.report.outcome)},
           {"captured", s.regrasp.report.captured},
           {"note", s.regrasp.report.note}}},
         {"regrasp_uv", s.truth.regrasp_uv ? J(*s.truth.regrasp_uv) : Json(nullptr)},
         {"regrasp_true_anchor", s.truth.regrasp_anchor},
         {"released_other", s.regrasp.released_other},
         {"verify",
          {{"checked", s.verify.checked},
           {"passed", s.verify.passed},
           {"why", s.verify.why},
           {"truth_pair_distance_m", s.verify.pair_distance >= 0 ? Json(s.verify.pair_distance) : Json(nullptr)}}},
         {"truth",
          {{"target_anchor", s.truth.target_anchor},
           {"predicted_error_m", s.truth.predicted_error},
           {"grasp_error_m", s.truth.grasp_error},
           {"regrasp_pattern_error_m", s.truth.regrasp_pattern_error},
           {"ladder", LadderJson(s.truth.ladder)}}},
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
          {"verification_rejected", rejected},
          {"belief_only",
           {{"step", belief_step >= 0 ? Json(belief_step + 1) : Json(nullptr)},
            {"regrasps", belief_regrasps},
            {"pair_distance", belief_pair_distance >= 0 ? Json(belief_pair_distance) : Json(nullptr)},
            {"unfolded", belief_unfolded}}},
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
