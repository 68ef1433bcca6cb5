// Evaluation of pose recognition on a split (paper Table "accuracy"): per category,
// pose accuracy with database instance 1 only, instance 2 only and both (with more than
// two instances: each instance alone, the first two — the paper's database — and all;
// report.json keys instance1 … instanceN, instances1_2, and "both" for all), unweighted
// (Eq. match) vs learned (Eq. bestmatch) distance; category accuracy; top-3 accuracy;
// grasp-point error; running time per query; and the report folder.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/json.h"
#include "common/mesh.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

// One test query with its labels and what its feature cost to produce.
struct EvalQuery {
  LabelledCode query;
  double fusion_seconds = -1;   // < 0: unknown
  double feature_seconds = -1;  // < 0: unknown
  std::string timing_source;    // where the two came from, e.g. "build.json entry_timing"
};

// Anchor positions on the flat pattern, metres, by (garment instance, anchor label).
using AnchorUvMap = std::map<std::pair<std::string, std::string>, Vec2>;

// The anchors a garment's symmetry maps this one onto: "left"/"right" swapped, "top"/
// "bottom" swapped, and both ("left_cuff" → {"right_cuff"}; the towel's "top_left" →
// {"top_right", "bottom_left", "bottom_right"}); empty when the label names no side. Every
// template's outline is left/right symmetric (the towel's also top/bottom: a rectangle;
// no other template has top/bottom labels). Where the back layer mirrors the front (towel,
// skirt, or a template's front/back difference set to 0, garments/anchors.md) a garment
// hung from a twin is the other's hang turned about the gripper (up to the triangulation
// and the simulation's chaos): no rotation-invariant feature can tell twins apart. Shirts
// and trousers differ front to back (neckline, back waist), which tells them apart.
// Reported beside the strict (paper's) accuracy as "twin credited".
std::vector<std::string> SymmetryTwins(const std::string& anchor);
// An anchor label's whole '_'-separated tokens ("left_leg_outer" -> left, leg, outer).
std::vector<std::string> AnchorTokens(const std::string& label);

struct EvalOptions {
  int top_k = 3;  // for the top-k accuracy (distinct anchors)
  void Validate() const;
};

struct EvalResult {
  Json report;  // everything; report.json is this
  // confusion[category] = {labels, counts[true][predicted]} for "both instances, learned
  // (or unweighted if the category has no weights)", category known.
  struct Confusion {
    std::vector<std::string> labels;
    std::vector<std::vector<int>> counts;
    std::string metric;
  };
  std::map<std::string, Confusion> confusion;
};

// Ranks every query once per (database subset × metric). `weights` may be null.
// Category known (paper protocol: the table is per garment type) for the pose table;
// the end-to-end column predicts the category by unweighted NN first (see recognizer.h).
// Grasp-point error: distance on the FLAT pattern of the query's own garment instance
// between the predicted and the true anchor (uv, from `uvs`), in cm; 0 for a correct
// anchor; falls back to the matched database instance's pattern when the query's
// instance lacks the predicted label; skipped (counted) when neither is known.
EvalResult Evaluate(const Database& db, const Weights* weights, const std::vector<EvalQuery>& queries,
                    const AnchorUvMap& uvs, const EvalOptions& options);

// Writes DIR/report.json, DIR/report.md, DIR/accuracy.png and DIR/confusion_<category>.png.
// `header` (release name, digest, split, weights file, command) is merged into report.json
// and printed at the top of report.md.
void WriteReport(const EvalResult& result, const Json& header, const std::filesystem::path& dir);

// The registration table (report.json "registration", see registration_eval.h) as
// markdown, with the paper's table; ReportMarkdown appends it when present.
std::string RegistrationMarkdown(const Json& table);

// The markdown tables alone (report.md without the header), for printing.
std::string ReportMarkdown(const Json& report);

}  // namespace drape::recognition
