// Learning the weighted Hamming distance (paper Eq. learn) with a RankSVM solved by
// the cutting-plane method (dlib::svm_rank_trainer, OCA), one w per category; and the
// weights artifact tied to a release digest.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "common/json.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

struct CalibrateOptions {
  double c = 10;              // RankSVM penalty C (paper: 10). dlib scales it by 1/#pairs.
  double epsilon = 0.001;     // OCA stopping tolerance on the ranking accuracy
  int max_iterations = 10000; // OCA iterations cap
  bool nonnegative = true;    // w >= 0, so w^T(x ⊕ q) stays a (weighted Hamming) distance
  WeightFrame frame = WeightFrame::kDatabase;  // which frame w indexes (see matcher.h)
  bool height_gates = true;   // choose height gates (recognizer.h); false: none, as the paper
  bool gate_train_queries = true;  // also select them on train entries vs the other instances
  void Validate() const;
};

struct CategoryCalibration {
  std::string category;
  int queries = 0;               // calibration queries of this category used
  int skipped = 0;               // queries without a relevant or a nonrelevant database entry
  long long pairs = 0;           // relevant × nonrelevant pairs (the constraints of Eq. learn)
  double accuracy_before = 0;    // fraction of pairs ordered right with w = 1 (plain Hamming)
  double accuracy_after = 0;     // … with the learned w
  double map_after = 0;          // mean average precision with the learned w (dlib)
  int top1_before = 0, top1_after = 0;  // calibration queries whose NN has the right anchor
  double nonzero_fraction = 0;   // share of weights > 1e-9
  double seconds = 0;            // timing only
};

// How the height gates were chosen: for each candidate τ (0 = no gate), how many
// selection queries got the right category (unweighted NN over the database) and the
// right anchor (category known, unweighted NN); the weakest gate within one standard
// error of the most right answers wins, separately for the two.
struct GateSelection {
  std::vector<double> taus;
  std::vector<int> category_right, pose_right;
  int queries = 0;             // selection queries with a known height
  int without_height = 0;      // left out: no height known
  HeightGates chosen;
};

struct CalibrationResult {
  Weights weights;  // categories with no usable query are absent (the runtime stays unweighted)
  std::vector<CategoryCalibration> categories;
  GateSelection gates;
  std::vector<std::string> warnings;
};

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
