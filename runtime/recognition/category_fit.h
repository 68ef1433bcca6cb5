// The garment category by registration (docs/recognition.md, "The category by
// registration"): an option beside the unweighted nearest neighbour of recognizer.h.
//
// The bits of Algorithm 1 scale the hung height and radius away, and a shirt held by a
// cuff can be nearer to a trouser leg than to any shirt entry by a few bits of ~500. The
// whole shapes differ far more between categories than between twins, so here the best
// entries of each category (by Eq. match, in the pool the category is chosen from:
// recognition's category height gate) have their hung mesh (hang.ply, turned by the
// matched rotation) registered onto the query's reconstruction — scale + rigid ICP
// (runtime/registration) — and the category is the one whose registered entry fits best:
//
//   f_c = the least SymmetricFit (m) among the category's first `per_category` entries,
//   d_c = the category's best Eq. match distance (bits),
//   score_c = f_c / min_c' f_c' + λ · d_c / min_c' d_c'   (λ = bits_weight; 0: the fit alone),
//
// and the decision is argmin_c score_c (ties: the smaller d_c, then the name). With
// `top_categories` N > 0 only the N categories of the smallest d_c take part.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "common/json.h"
#include "common/mesh.h"
#include "generator/release/release.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

// The defaults were chosen on train + calibration queries of paper 2.3.0 (`drape eval` with
// the options file's eval.category_fit_selection: 76 of 77 right against the nearest neighbour's 70, and 76 by
// the nested leave-one-out of the choice; docs).
struct CategoryFitOptions {
  int per_category = 2;    // entries registered per category: its nearest by Eq. match in the pool
  int top_categories = 2;  // only the N categories of the smallest best distance (0 = every one in the pool)
  double bits_weight = 0;  // λ above (>= 0)
  bool scale = true;       // registration's scale step (l_T / l_S)
  int threads = 1;         // candidates (or queries) registered in parallel; results do not depend on it
  void Validate() const;   // throws drape::Error naming the bad field
};

// One database entry registered onto the query.
struct FitCandidate {
  int entry = -1;
  std::string id, category;
  int distance = 0, rotation = 0;  // Eq. match against the query
  double fit = -1;                 // SymmetricFit after scale + ICP (m); < 0: not registered
  std::string failure;             // why not, when fit < 0
  double seconds = 0;              // timing only
};

struct CategoryFit {
  std::string category;                  // decided; "" when no candidate could be registered
  std::vector<FitCandidate> candidates;  // by category name, then distance
  std::map<std::string, double> scores;  // score_c of the categories that took part
  double seconds = 0;                    // timing only: reading, registering, measuring
};

// The entries a category is chosen from, as Recognizer::Rank does: every entry (but those
// of garment instance `exclude_instance`, for a database entry queried against the
// others) through the category height gate τ for a query `query_height` m tall.
std::vector<int> CategoryPool(const Database& db, double query_height, double tau,
                              const std::string& exclude_instance = "");

// The candidates of a non-empty `pool`: per category its `per_category` nearest entries by
// Eq. match (`matches` indexed by entry; ties: the lower entry), of the `top_categories`
// nearest categories (0 = all); not yet registered. Throws drape::Error on bad options.
std::vector<FitCandidate> ChooseFitCandidates(const Database& db, const std::vector<int>& pool,
                                              const std::vector<Match>& matches, const CategoryFitOptions& options);

// The category decided from registered candidates (the rule above), using only each
// category's first `per_category` candidates and the `top_categories` nearest categories,
// so that candidates chosen for larger settings can be re-decided for smaller ones.
// Candidates with fit < 0 are ignored; a category with none registered takes no part.
// "" when no candidate is usable. `scores` (optional) gets score_c.
std::string DecideByFit(const std::vector<FitCandidate>& candidates, const CategoryFitOptions& options,
                        std::map<std::string, double>* scores = nullptr);

// `mesh` turned about the gripper's y axis by Eq. match's rotation k of Φ sectors (the
// database entry brought to the query's orientation: R_k x ≈ q).
TriMesh TurnedToQuery(const TriMesh& mesh, int rotation, int sectors);

// Registers each candidate's hung mesh (`hung_mesh(entry)`, object frame), turned by its
// rotation, onto `recon` (rigid only: scale + ICP) and measures its fit. A candidate
// whose mesh cannot be read or registered keeps fit < 0 and its failure; never throws for
// one candidate.
void RegisterFitCandidates(std::vector<FitCandidate>& candidates, const TriMesh& recon, int sectors,
                           const std::function<TriMesh(int)>& hung_mesh, const CategoryFitOptions& options);

// The whole decision for one query. Throws drape::Error on bad options or an empty pool.
CategoryFit DecideCategoryByFit(const Database& db, const std::vector<int>& pool, const std::vector<Match>& matches,
                                const TriMesh& recon, const std::function<TriMesh(int)>& hung_mesh,
                                const CategoryFitOptions& options);

Json ToJson(const CategoryFit& fit);

// The hung meshes of a release's database entries (hang.ply), read once each; safe to
// call from several threads.
std::function<TriMesh(int)> ReleaseHungMeshes(const Release& release, const Database& db);

// The decision for a query that `rec` ranks with options `o` (`matches`: its Eq. match
// against every entry): the pool is recognition's category gate for `o` (its query
// height, its gates). The unfolding loop's first step and EntryCategoryByFit.
CategoryFit RecognitionCategoryByFit(const Database& db, const Recognizer& rec, const RecognizeOptions& o,
                                     const std::vector<Match>& matches, const TriMesh& recon,
                                     const std::function<TriMesh(int)>& hung_mesh, const CategoryFitOptions& options);

// The category of release entry `entry`'s query `q` by registration onto its recon.ply
// (`drape recognize --entry` and the Python binding, by default; RecognitionCategoryByFit).
// Throws drape::Error when `o` already names a category or the entry has no recon.ply.
CategoryFit EntryCategoryByFit(const Release& release, const Database& db, const Recognizer& rec, const Code& q,
                               const RecognizeOptions& o, const std::string& entry, const CategoryFitOptions& options);

// `drape eval --category-fit`: for every query of `queries` (a split of `release`), the
// category by registration beside the unweighted nearest neighbour, with the same
// category gate (the weights', none without weights), and the end-to-end pose (right
// category and anchor, both database instances, unweighted / learned) with that
// category. report.json "category_fit": {"options", "categories": [per category and
// "all"], "per_query", "seconds_per_query"}.
Json EvaluateCategoryFit(const Release& release, const Database& db, const Weights* weights,
                         const std::vector<EvalQuery>& queries, const CategoryFitOptions& options);

// `drape eval`, eval.category_fit_selection: the settings chosen on train + calibration only.
// Queries: `calibration` (ranked against the whole database) and every database entry
// ranked against the entries of the other garment instances (leave one instance out;
// entries whose category has no other instance are left out: they cannot be right). Each
// query's candidates are registered once for the largest setting; every setting of the
// grid (per_category 1–3, top_categories all / 2, λ in {0, 0.25, 0.5, 1, 2}) and the
// unweighted nearest neighbour are then counted; the one-standard-error rule chooses, and
// a nested leave-one-out of that choice (selection.h: each query answered by the setting
// the rule chooses on the others) says what the choice is worth. Returns {"grid": [...],
// "queries", "chosen", "nearest_neighbour", "nested_leave_one_out", "per_query", ...}.
Json SelectCategoryFit(const Release& release, const Database& db, double category_gate,
                       const std::vector<LabelledCode>& calibration, int threads);

}  // namespace drape::recognition
