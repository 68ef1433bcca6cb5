// Learning the weighted Hamming distance (paper Eq. learn) with a RankSVM solved by
// the cutting-plane method (dlib::svm_rank_trainer, OCA), one w per category; and the
// weights artifact tied to a release digest.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/json.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/recognition/selection.h"

namespace drape::recognition {

// What the RankSVM's quadratic term pulls w towards.
//  kZero:    ½‖w‖², w ≥ 0 — the paper's plain RankSVM. With 4096 free weights and a few
//            hundred pairs it fits its pairs exactly, and nothing ties it to the
//            unweighted distance that works.
//  kUniform: ½‖w − 1‖² — w = 1 + δ with ½‖δ‖² penalised (dlib's prior): the unweighted
//            (Hamming) distance is the solution as C → 0, and C sets how far the data may
//            move w from it. Margins are in bits. dlib cannot combine a prior with w ≥ 0:
//            negative weights are set to 0 afterwards and counted (CategoryCalibration).
enum class Regularizer { kZero, kUniform };
const char* RegularizerName(Regularizer r);
Regularizer ParseRegularizer(const std::string& name);  // "zero" | "uniform"

// Which bits share one weight.
//  kBit:     4096 free weights (the paper).
//  kAnnulus: one weight per (layer, ring), shared by the Φ sectors: L·R = 256. A category's
//            w serves every database entry of it, and an entry's sector 0 points wherever
//            its garment happened to face when swept (Eq. match turns the query, not the
//            frame into a common one), so a weight per sector has no meaning shared across
//            entries; layer (height) and ring (radius) do, both normalised by Algorithm 1.
//  kLayer:   one weight per layer: L = 16.
enum class WeightTying { kBit, kAnnulus, kLayer };
const char* WeightTyingName(WeightTying t);
WeightTying ParseWeightTying(const std::string& name);  // "bit" | "annulus" | "layer"

struct CalibrateOptions {
  double c = 10;                                 // RankSVM penalty C (paper: 10). dlib scales it by 1/#pairs.
  Regularizer regularizer = Regularizer::kZero;  // the paper's; `drape calibrate` defaults to kUniform
  WeightTying tying = WeightTying::kBit;         // the paper's
  double epsilon = 0.001;                        // OCA stopping tolerance on the ranking accuracy
  int max_iterations = 10000;                    // OCA iterations cap
  bool nonnegative = true;                       // w >= 0, so w^T(x ⊕ q) stays a (weighted Hamming) distance
  WeightFrame frame = WeightFrame::kDatabase;    // which frame w indexes (see matcher.h)
  bool height_gates = true;                      // choose height gates (recognizer.h); false: none, as the paper
  bool gate_train_queries = true;                // also select them on train entries vs the other instances
  void Validate() const;
};

struct CategoryCalibration {
  std::string category;
  int queries = 0;                      // calibration queries of this category used
  int skipped = 0;                      // queries without a relevant or a nonrelevant database entry
  long long pairs = 0;                  // relevant × nonrelevant pairs (the constraints of Eq. learn)
  double accuracy_before = 0;           // fraction of pairs ordered right with w = 1 (plain Hamming)
  double accuracy_after = 0;            // … with the learned w
  double map_after = 0;                 // mean average precision with the learned w (dlib)
  int top1_before = 0, top1_after = 0;  // calibration queries whose NN has the right anchor
  double nonzero_fraction = 0;          // share of weights > 1e-9
  int clipped = 0;                      // weights (of 4096) the uniform prior left < 0, set to 0
  double mean_abs_departure = 0;        // mean |w_b − 1| over the bits
  double seconds = 0;                   // timing only
};

// How the height gates were chosen: for each candidate τ (0 = no gate), how many
// selection queries got the right category (unweighted NN over the database) and the
// right anchor (category known, unweighted NN); ChooseHeightGates chooses from the counts.
struct GateSelection {
  std::vector<double> taus;
  std::vector<int> category_right, pose_right;
  int queries = 0;         // selection queries with a known height
  int without_height = 0;  // left out: no height known
  HeightGates chosen;
};

// The gates from the counts of `queries` selection queries, `taus` weakest first (0 =
// none): the category gate is the weakest τ with the most right categories; the pose
// gate the weakest τ within one standard error of the most right anchors
// (OneStandardError, selection.h). Why the two differ: a nested leave-one-out of each rule
// over the selection queries of two recipe seeds (docs/recognition.md, "Which rule chooses
// the category gate"): for the category the most right held 70 / 62 of 85 right against
// 65 / 57 for the one-SE rule, which on seed 2017 let the category gate widen to 0.5.
// No gate (0) without queries.
HeightGates ChooseHeightGates(const std::vector<double>& taus, const std::vector<int>& category_right,
                              const std::vector<int>& pose_right, int queries);

struct CalibrationResult {
  Weights weights;  // categories with no usable query are absent (the runtime stays unweighted)
  std::vector<CategoryCalibration> categories;
  GateSelection gates;
  std::vector<std::string> warnings;
};

// OneStandardError (the rule choosing the gates and weights): selection.h.

// The height-gate search on its own. Selection queries: `queries`, and with
// options.gate_train_queries every database entry; each is ranked against the database
// entries of other garment instances only (an entry would find itself otherwise).
GateSelection SelectHeightGates(const Database& db, const std::vector<LabelledCode>& queries,
                                const CalibrateOptions& options);

// For each calibration query q_j of category c and each database entry i of category c:
// entries with the query's anchor are relevant, the others nonrelevant; a pair's vector is
// x̂_i ⊕ q_j (0/1, Φ·R·N values) with x̂_i at the Eq. match rotation. Queries of a
// category absent from the database, or without a relevant/nonrelevant entry, are
// skipped with a warning. `release_digest` is stored in the weights.
CalibrationResult Calibrate(const Database& db, const std::vector<LabelledCode>& queries,
                            const CalibrateOptions& options, const std::string& release_digest);

// Leave-one-garment-instance-out cross-validation of calibration settings. Per category,
// each garment instance h among the queries is held out in turn: weights are learned on
// the queries of the other instances ranked against the database entries of the other
// instances (h's entries take part in no pair), and each query of h is then ranked,
// category known, against the database entries of every instance but h, through the
// pose height gate `gates.pose`, as `drape eval` does. A setting with c == 0 is the
// unweighted distance. Queries are those given (calibration and train); no test split.
struct CvSetting {
  Regularizer regularizer = Regularizer::kUniform;
  WeightTying tying = WeightTying::kAnnulus;
  double c = 0;          // 0: unweighted
  bool eligible = true;  // false: reported only (the paper's setting)
  int right = 0;         // held-out queries whose nearest entry has their anchor
  std::map<std::string, int> right_by_category;
  std::string Name() const;
};
struct CrossValidation {
  std::vector<CvSetting> settings;  // in order of complexity: unweighted first
  int queries = 0;                  // held-out queries that had a database entry to rank
  std::map<std::string, int> queries_by_category;
  int folds = 0;    // (category, held-out instance) pairs
  int chosen = -1;  // index into settings (one-standard-error rule)
};
// The default grid: unweighted; uniform prior × {layer, annulus, bit} × C ∈ {0.03, 0.1,
// 0.3, 1, 3, 10, 100}; and the paper's plain RankSVM (C = 10, per bit), not eligible.
std::vector<CvSetting> DefaultCvGrid();
// Among the eligible settings, the first (simplest) whose count is within one standard
// error sqrt(p(1 − p)/n)·n of the best.
CrossValidation CrossValidate(const Database& db, const std::vector<LabelledCode>& queries,
                              const CalibrateOptions& base, const HeightGates& gates, std::vector<CvSetting> settings);
Json ToJson(const CrossValidation& cv);

// The artifact: DIR/weights.json (digest, shape, options, stats, and for each category
// the offset of its weights in weights.bin and their SHA-256) and DIR/weights.bin
// (little-endian float64). Written atomically.
void SaveWeights(const Weights& w, const std::filesystem::path& dir);
// Reads DIR/weights.json (or the .json path given) and its .bin. Throws drape::Error if
// a file is missing or corrupt, or if the weights were learned on a release whose digest
// differs from `expected_digest` (unless it is empty).
Weights LoadWeights(const std::filesystem::path& path, const std::string& expected_digest);

Json ToJson(const CategoryCalibration& c);
Json ToJson(const GateSelection& g);

}  // namespace drape::recognition
