// The recognise phase (trial.h): Eq. match of the hang's feature against every database
// entry; the trial's category by registration at every hang (category.h); the pose
// within it (recognition/recognizer.h); the plan prior after a regrasp.
#include <algorithm>

#include "common/error.h"
#include "common/field_error.h"
#include "common/timing.h"
#include "runtime/recognition/category_fit.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/unfolding/category.h"
#include "runtime/unfolding/trial.h"

namespace drape::unfolding {

namespace rec = drape::recognition;

void RecogniseOptions::Validate() const {
  if (!(refit_absent_penalty >= 0))
    BadField(refit_absent_penalty, "RecogniseOptions.refit_absent_penalty", "must be >= 0");
  if (plan_prior_top_k < 0 || plan_prior_top_k > 5)
    BadField(plan_prior_top_k, "RecogniseOptions.plan_prior_top_k", "must be in 0..5");
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

int TrustedAimedEntry(const rec::Recognition& r, const std::string& aimed) {
  return FirstAimedOrTwin(r.entries, r.entries.size(), aimed);
}

void Trial::Recognise(Step& s, const Feature& code) {
  const auto t0 = Clock::now();
  const RecogniseOptions& o = o_.recognise;
  rec::RecognizeOptions ro;
  ro.weighted = o.weighted;
  const TriMesh& recon = s.observe.recon;
  ro.query_height = recon.V.col(1).maxCoeff() - recon.V.col(1).minCoeff();  // height gates
  ro.top_k = std::max(ro.top_k, o.plan_prior_top_k);
  // RegistrationCandidates filters them; TrustedAimedEntry looks beyond the top anchors.
  ro.top_entries = model_.database().size();
  // Eq. match against every entry once, for the category by registration and the
  // recognition (Recognizer::Recognize is the same Rank of the same matches).
  const rec::Recognizer& recognizer = model_.recognizer(o.weighted);
  const rec::PreparedQuery q(code);
  std::vector<rec::Match> matches;
  model_.database().matcher().MatchAll(q, &matches);
  // The garment in the gripper does not change between steps: the pose is recognised
  // within the trial's category, which the hangs so far decide.
  const bool changed = UpdateCategory(s, matches, recognizer, ro);
  ro.category = o.category_known ? category_ : trial_category_;
  Recognised& r = s.recognise;
  r.recognition = recognizer.Rank(q, matches, ro);
  if (!r.category_fit.is_null() && !ro.category.empty()) r.recognition.category_source = "registration";
  r.recognition.match_seconds = Since(t0);
  r.category = r.recognition.category;
  r.category_switched = changed;
  if (changed) {
    // The aimed anchor was planned on the other category's model: neither kept nor
    // registered as a candidate, and the holder was not placed by an aimed regrasp.
    s.note = "category now " + r.category + " (the fits of " + std::to_string(fit_scores_.size()) +
             " hangs): recognition's anchor, not the one aimed at";
    holder_regrasped_ = false;
  }
  r.recognised_anchor = r.recognition.anchor;
  ApplyPlanPrior(s);
  res_.times.recognition += Since(t0);
  s.truth.recognised_right = r.recognition.category == category_ && r.recognition.anchor == s.truth.held_anchor;
  if (trial_category_.empty()) trial_category_ = r.recognition.category;
}

// The hang's category by registration (recognition/category_fit.h; its scores kept), and
// the trial's category the least score summed over the hangs so far (SummedFitCategory;
// ties keep it). None with category_known. Returns whether a later hang changed it.
bool Trial::UpdateCategory(Step& s, const std::vector<rec::Match>& matches, const rec::Recognizer& recognizer,
                           const rec::RecognizeOptions& ro) {
  if (o_.recognise.category_known) return false;
  const rec::CategoryFit fit = rec::RecognitionCategoryByFit(
      model_.database(), recognizer, ro, matches, s.observe.recon, [this](int e) { return model_.HungMesh(e); },
      rec::CategoryFitOptions{});
  s.recognise.category_fit = rec::ToJson(fit);
  if (!fit.scores.empty()) fit_scores_.push_back(fit.scores);
  // "" when no entry could be registered: recognition's nearest neighbour then decides.
  const std::string before = trial_category_;
  if (before.empty()) {
    trial_category_ = fit.category;
    return false;
  }
  if (const std::string c = SummedFitCategory(fit_scores_, before, o_.recognise.refit_absent_penalty); !c.empty())
    trial_category_ = c;
  return trial_category_ != before;
}

// One hang tells neighbouring anchors apart poorly (a trouser leg's inner and outer corner
// hang alike), while the arm knows where it was sent: the aimed anchor, or its twin, is
// kept, as recognition's top-k anchor when it ranks it among its top k, else as its
// best-scored entry.
void Trial::ApplyPlanPrior(Step& s) const {
  Recognised& r = s.recognise;
  r.aimed_anchor = aimed_;
  if (r.category_switched) return;
  r.prior_rank = PlanPriorRank(r.recognition, aimed_, o_.recognise.plan_prior_top_k);
  if (r.prior_rank >= 0) {
    r.recognition.best = r.recognition.top[r.prior_rank];
  } else {
    const int e = TrustedAimedEntry(r.recognition, aimed_);
    if (e < 0) return;
    r.prior_trusted = true;
    r.recognition.best = r.recognition.entries[e];
  }
  r.recognition.anchor = r.recognition.best.anchor;
}

}  // namespace drape::unfolding
