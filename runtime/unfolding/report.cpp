#include "runtime/unfolding/report.h"

#include <cstdio>
#include <sstream>

namespace drape::unfolding {

TableRow Summarise(const std::string& category, const std::string& variant, const std::vector<TrialResult>& trials) {
  TableRow r;
  r.category = category;
  r.variant = variant;
  for (const TrialResult& t : trials) {
    ++r.trials;
    r.recognised += t.recognition_success;
    r.regrasped += t.regrasp_success;
    r.seconds += t.seconds;
    if (t.placed) {
      ++r.placed;
      r.coverage += t.coverage;
    }
    for (size_t i = 0; i < kUnfoldedWithin.size(); ++i)
      r.unfolded_within[i] +=
          t.converged && t.final_pair_distance >= 0 && t.final_pair_distance <= kUnfoldedWithin[i] + 1e-12;
    r.declared_not_unfolded += t.converged && !t.unfolded;
    r.rejected += t.rejected;
    if (t.belief_step >= 0) {
      r.belief_unfolded += t.belief_unfolded, r.belief_not_unfolded += !t.belief_unfolded;
      if (t.belief_unfolded) r.belief_regrasps_on_success += t.belief_regrasps;
    }
    if (t.unfolded) {
      ++r.unfolded;
      r.regrasps_on_success += t.regrasps;
    }
    r.times.simulation += t.times.simulation, r.times.sensing += t.times.sensing;
    r.times.fusion += t.times.fusion, r.times.recognition += t.times.recognition;
    r.times.registration += t.times.registration, r.times.refinement += t.times.refinement;
  }
  if (r.unfolded) r.regrasps_on_success /= r.unfolded;
  if (r.belief_unfolded) r.belief_regrasps_on_success /= r.belief_unfolded;
  if (r.placed) r.coverage /= r.placed;
  if (r.trials) r.seconds /= r.trials;
  return r;
}

namespace {
// The paper's table (Baxter, real garments, 10 trials each).
struct PaperRow {
  const char* garment;
  int recognised, regrasped, unfolded;
  double regrasps;
};
const PaperRow kPaper[] = {{"Sweatshirt", 9, 8, 8, 1.6}, {"Sweater", 8, 8, 7, 1.6}, {"Knitwear", 9, 9, 8, 1.7},
                           {"Jeans", 9, 9, 9, 1.3},      {"Pants", 8, 10, 9, 1.4},  {"Leggings", 8, 9, 8, 1.4},
                           {"Shorts", 7, 8, 7, 1.9}};
}  // namespace

Json ReportJson(const std::vector<TableRow>& rows) {
  Json out{{"rows", Json::array()}};
  for (const TableRow& r : rows) {
    Json within = Json::object();
    for (size_t i = 0; i < kUnfoldedWithin.size(); ++i) {
      char key[16];
      std::snprintf(key, sizeof key, "%.2f", kUnfoldedWithin[i]);
      within[key] = r.unfolded_within[i];
    }
    out["rows"].push_back(
        {{"category", r.category},
         {"variant", r.variant},
         {"trials", r.trials},
         {"successful_recognition", r.recognised},
         {"successful_regrasping", r.regrasped},
         {"successful_unfolding", r.unfolded},
         {"avg_regrasps_success_only", r.unfolded ? Json(r.regrasps_on_success) : Json(nullptr)},
         {"unfolded_within_m", within},
         {"declared_not_unfolded", r.declared_not_unfolded},
         {"verification_rejected", r.rejected},
         {"belief_only",
          {{"successful_unfolding", r.belief_unfolded},
           {"declared_not_unfolded", r.belief_not_unfolded},
           {"avg_regrasps_success_only", r.belief_unfolded ? Json(r.belief_regrasps_on_success) : Json(nullptr)}}},
         {"placed_flat", r.placed},
         {"mean_coverage", r.placed ? Json(r.coverage) : Json(nullptr)},
         {"seconds_per_trial", r.seconds},
         {"stage_seconds", r.times.ToJson()}});
  }
  Json paper = Json::array();
  for (const PaperRow& p : kPaper)
    paper.push_back({{"garment", p.garment},
                     {"trials", 10},
                     {"successful_recognition", p.recognised},
                     {"successful_regrasping", p.regrasped},
                     {"successful_unfolding", p.unfolded},
                     {"avg_regrasps_success_only", p.regrasps}});
  out["paper"] = {{"rows", paper},
                  {"average",
                   {{"successful_recognition", 8.3},
                    {"successful_regrasping", 8.7},
                    {"successful_unfolding", 8.0},
                    {"avg_regrasps_success_only", 1.6}}}};
  return out;
}

std::string ReportMarkdown(const std::vector<TableRow>& rows) {
  std::ostringstream os;
  os << "| garment | variant | # trials | successful recognition | successful regrasping | successful unfolding | "
        "avg. # regrasps (success only) | declared, not unfolded | on the belief alone: unfolded / declared, not / "
        "regrasps | stops not verified | unfolded within 4 / 6 / 8 / 10 cm | coverage "
        "(placed) | "
        "s / trial |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[256];
  for (const TableRow& r : rows) {
    char cov[32] = "–", regrasps[32] = "–";
    if (r.placed) std::snprintf(cov, sizeof cov, "%.2f (%d)", r.coverage, r.placed);
    if (r.unfolded) std::snprintf(regrasps, sizeof regrasps, "%.1f", r.regrasps_on_success);  // as the paper's rows
    const auto& w = r.unfolded_within;
    char belief[64] = "–";
    if (r.belief_unfolded)
      std::snprintf(belief, sizeof belief, "%d / %d / %.1f", r.belief_unfolded, r.belief_not_unfolded,
                    r.belief_regrasps_on_success);
    else
      std::snprintf(belief, sizeof belief, "0 / %d / –", r.belief_not_unfolded);
    std::snprintf(buf, sizeof buf,
                  "| %s | %s | %d | %d/%d | %d/%d | %d/%d | %s | %d | %s | %d | %d / %d / %d / %d | %s | %.0f |\n",
                  r.category.c_str(), r.variant.c_str(), r.trials, r.recognised, r.trials, r.regrasped, r.trials,
                  r.unfolded, r.trials, regrasps, r.declared_not_unfolded, belief, r.rejected, w[0], w[1], w[2], w[3],
                  cov, r.seconds);
    os << buf;
  }
  os << "| **paper (Baxter, average of 7 garments)** | | 10 | 8.3/10 | 8.7/10 | 8.0/10 | 1.6 | – | – | – | – | – | |\n";
  for (const PaperRow& p : kPaper) {
    std::snprintf(buf, sizeof buf, "| paper: %s | | 10 | %d/10 | %d/10 | %d/10 | %.1f | – | – | – | – | – | |\n",
                  p.garment, p.recognised, p.regrasped, p.unfolded, p.regrasps);
    os << buf;
  }
  return os.str();
}

}  // namespace drape::unfolding
