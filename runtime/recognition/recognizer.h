// Pose recognition against an in-memory database of labelled features (paper
// §"Pose Estimation"): nearest neighbour under Eq. match, then the learned weighted
// Hamming distance of Eq. bestmatch with one weight vector per category.
//
// Ranking across categories: the learned w of one category is not on the scale of
// another's (each is fitted by its own RankSVM, and only ratios inside one category
// mean anything), so weighted distances are never compared across categories. As in
// the paper — which learns "a weight vector w for each type of garment" and reports
// accuracy per garment type — the category is decided first by the unweighted nearest
// neighbour over the whole database (Eq. match, one common scale: bits), unless the
// caller knows it (RecognizeOptions::category); the pose (anchor) is then the nearest
// neighbour inside that category under that category's w (Eq. bestmatch).
//
// Height gates (an addition to the paper, off unless the weights carry them): Algorithm 1
// scales the garment's height away (its N layers span the surface's y extent), so shapes
// that differ mainly in scale — shorts and pants hung by the waist, a shirt by its cuff
// or by its hem — can give nearly the same bits. The hung height below the gripper is
// measured anyway (the reconstruction's y extent, the H of Algorithm 1), and both steps
// may keep only the entries whose height is within a factor of the query's: an entry
// passes gate τ when |ln(h_query / h_entry)| ≤ τ. A gate that no entry passes is widened
// to the nearest entry's ratio + τ; entries or queries of unknown height (0) always pass. `drape calibrate`
// chooses τ on train + calibration queries (calibrate.h).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/json.h"
#include "common/mesh.h"
#include "runtime/recognition/matcher.h"

namespace drape::recognition {

// What the database knows about one of its features.
struct EntryLabel {
  std::string id;                   // release entry id
  std::string split;                // "train" for the database
  std::string category;             // garment category, e.g. "pants"
  std::string instance;             // garment instance, e.g. "pants-M-s1"
  std::string anchor;               // anchor label the garment hangs from, e.g. "waist_left"
  std::string material;             // material name (informative)
  int anchor_vertex = -1;           // vertex of the anchor in the entry's meshes, -1 unknown
  std::optional<Vec2> anchor_uv;    // anchor on the flat pattern (metres), if known
  std::optional<Vec3> anchor_hung;  // anchor vertex on the hung mesh (object frame, metres)
  double height = 0;                // hung height: the reconstruction's y extent (m), 0 unknown
  int hang = 0;                     // which of the anchor's hangs (record "hang_index"; 0 = the anchor's own)
};

struct LabelledCode {
  EntryLabel label;
  Code code;
};

// The database: features of one shape, labels, and an index by category and instance.
class Database {
 public:
  Database() = default;
  // Throws drape::Error naming the entry if a feature is malformed or of another shape.
  explicit Database(std::vector<LabelledCode> entries, Kernel kernel = Kernel::kAuto);

  int size() const { return static_cast<int>(labels_.size()); }
  bool empty() const { return labels_.empty(); }
  const EntryLabel& label(int i) const { return labels_[i]; }
  const Code& code(int i) const { return codes_[i]; }
  const Matcher& matcher() const { return matcher_; }
  Matcher& mutable_matcher() { return matcher_; }

  // Sorted category names; sorted instance names of one category (empty if unknown).
  std::vector<std::string> categories() const;
  std::vector<std::string> instances(const std::string& category) const;
  bool HasCategory(const std::string& c) const { return by_category_.count(c) > 0; }
  const std::vector<int>& EntriesOf(const std::string& category) const;
  // Shape of the features; 0 when empty.
  int layers() const { return matcher_.layers(); }
  int rings() const { return matcher_.rings(); }
  int sectors() const { return matcher_.sectors(); }

 private:
  std::vector<EntryLabel> labels_;
  std::vector<Code> codes_;
  Matcher matcher_;
  std::map<std::string, std::vector<int>> by_category_;
};

// Height gates, τ as a bound on |ln(h_query / h_entry)|; 0 = no gate (see above).
struct HeightGates {
  double category = 0;  // on the entries the category's nearest neighbour is chosen from
  double pose = 0;      // on the entries of the category the pose is chosen from
  bool operator==(const HeightGates&) const = default;
};

// Whether an entry of height `entry_h` passes gate `tau` for a query of height `query_h`.
bool PassesHeightGate(double query_h, double entry_h, double tau);
// The entries of `pool` that pass the gate; when none does, those within the nearest
// entry's |ln ratio| + τ.
std::vector<int> HeightGated(const Database& db, const std::vector<int>& pool, double query_h, double tau);

// The entry of a non-empty `pool` nearest under Eq. match (`matches` indexed by entry;
// ties: the first in the pool).
int NearestUnweighted(const std::vector<int>& pool, const std::vector<Match>& matches);

// Learned weights, one vector per category (bits in `frame`; see matcher.h).
struct Weights {
  std::string release_digest;  // digest of the release they were learned on
  int layers = 0, rings = 0, sectors = 0;
  WeightFrame frame = WeightFrame::kDatabase;
  std::map<std::string, std::vector<double>> per_category;
  Json options = Json::object();  // training options (C, epsilon, …)
  Json stats = Json::object();    // training statistics
  HeightGates height_gates;       // chosen by calibration; none in weights from before them
};

struct RecognizeOptions {
  int top_k = 5;                       // distinct (category, anchor) labels listed
  int top_entries = 0;                 // database entries listed in Recognition::entries (0 = none)
  std::string category;                // known category ("" = predict by unweighted NN)
  std::vector<std::string> instances;  // restrict the pose search to these database garment
                                       // instances (empty = all)
  bool weighted = true;                // use the category's learned w when there is one
  double query_height = 0;             // hung height of the query (m); 0 = unknown: no height gates
  bool height_gates = true;            // apply the weights' height gates (false: Algorithm 1 alone, as the paper)
  std::optional<HeightGates> gates;    // these gates instead of the weights' (calibration's search)
  void Validate() const;
};

struct Candidate {
  int entry = -1;  // database index
  std::string id, category, instance, anchor;
  int distance = 0;  // Eq. match, bits
  int rotation = 0;  // best k (R_k x ≈ q)
  double score = 0;  // what was ranked: weighted distance, or distance if unweighted
};

struct Recognition {
  std::string category;  // predicted (or given) category
  std::string
      category_source;  // "given" | "unweighted_nn" | "registration" (drape recognize --category-fit, category_fit.h)
  std::string anchor;   // predicted anchor label
  Candidate best;       // the matched database entry
  std::vector<Candidate> top;  // best entry of each of the top_k distinct anchors, best first
  // The top_entries entries of the category (any anchor; the instance restriction kept,
  // the pose height gate not applied), best first by the same score: the registration
  // candidates (runtime/unfolding/candidates.h) are checked by their fit instead.
  std::vector<Candidate> entries;
  bool weighted = false;     // whether a learned w ranked the pose
  double query_height = 0;   // as given (m)
  HeightGates gates;         // the gates applied (0: none)
  int category_pool = 0;     // entries the category was chosen from
  int pose_pool = 0;         // entries the pose was chosen from
  int compared = 0;          // database entries compared (× Φ rotations each)
  double match_seconds = 0;  // timing only
};

class Recognizer {
 public:
  // `weights` may be null (unweighted); it must outlive the recognizer. Throws
  // drape::Error if the weights' feature shape differs from the database's.
  Recognizer(const Database& db, const Weights* weights);

  // Throws drape::Error on an empty database, a query of another shape, an unknown
  // category or instance.
  Recognition Recognize(const Code& query, const RecognizeOptions& options) const;
  // Same with the query already prepared and Eq. match already run against every
  // entry (lets evaluation rank one query several ways for the price of one match).
  Recognition Rank(const PreparedQuery& q, const std::vector<Match>& matches, const RecognizeOptions& options) const;

  bool HasWeights(const std::string& category) const { return weights_.count(category) > 0; }
  // The height gates Rank applies with these options.
  HeightGates GatesFor(const RecognizeOptions& options) const;

 private:
  const Database& db_;
  HeightGates gates_;
  std::map<std::string, PreparedWeights> weights_;
};

Json ToJson(const Recognition& r);

}  // namespace drape::recognition
