// Recipes: the YAML file that says everything a build needs (recipes/README.md
// documents every key). Parsing is strict: an unknown or misspelt key, a wrong
// type, an out-of-range value, a missing file, a path escaping the recipe's
// folder, an unknown material or anchor label throws drape::Error with the
// message "recipe.yaml:LINE:COL: key.path: what" (line and column 1-based).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/option_keys.h"
#include "garments/templates.h"
#include "generator/feature/feature.h"
#include "generator/fusion/fusion.h"
#include "generator/hang/hang.h"
#include "generator/hang/material.h"
#include "generator/sweep/sweep.h"

namespace drape {

// One entry of `garments:`: a template or an imported file, with a number of
// seeded instances and the material variants and anchors to hang it by.
struct GarmentSpec {
  std::string name;                                 // unique within the recipe; first part of job keys
  std::string template_name;                        // empty for imports
  std::filesystem::path file;                       // absolute, imports only
  std::filesystem::path anchors;                    // absolute, imports only (may be empty)
  std::string file_as_written, anchors_as_written;  // the recipe's text for them (a release keys its copies by it)
  double unit_scale = 1.0;                          // imports: file units → metres
  std::string category;                             // template's category, or `category:` for imports
  TemplateOptions options;                          // size, params, edge_length, ... (seed set per instance)
  int instances = 1;
  std::vector<std::string> materials;          // names in Recipe::materials
  std::vector<std::string> anchor_labels;      // the labels to hang from (resolved; never empty)
  std::vector<std::string> all_anchor_labels;  // every label the garment has, in its order
  void Validate() const;                       // throws drape::FieldError
};

// Perturbations applied to the sensed splits (calibration, test).
struct Perturbation {
  double grasp_offset = 0.0;  // metres on the flat pattern, random direction per job
  // σ per axis (metres, on the flat pattern) of a Gaussian grasp miss drawn per job: a
  // robot's grasp. Exclusive with grasp_offset.
  double grasp_miss = 0.0;
  double size_scale_min = 1.0, size_scale_max = 1.0;  // uniform per instance
  double material_jitter = 0.0;  // fraction: each measured material value × (1 + U(−j, j)), per instance
  // The hung garment turned about the gripper (y) axis by a seeded angle U(0, 2π) before
  // the sweep: a grasp at another orientation (the feature is rotation-invariant only
  // in steps of 2π/Φ).
  bool turn = false;
  // σ of the turning gripper's encoder error, degrees per frame (FusionOptions::
  // pose_noise_degrees of this split's fusion).
  double gripper_pose_noise = 0.0;
  bool Any() const {
    return grasp_offset > 0 || grasp_miss > 0 || size_scale_min != 1.0 || size_scale_max != 1.0 ||
           material_jitter > 0 || turn || gripper_pose_noise > 0;
  }
  void Validate() const;  // throws drape::FieldError
};

// Which instances of one garment go into a split.
struct SplitSelector {
  std::string garment;                 // GarmentSpec::name
  std::vector<int> instances;          // 0-based instance indices, ascending
  std::vector<std::string> materials;  // subset of the garment's materials (empty = all)
  std::vector<std::string> anchors;    // subset of the garment's anchors (empty = the garment's)
  int max_anchors = 0;                 // > 0: a seeded sample of this many anchors per instance
  void Validate() const;               // throws drape::FieldError
};

// How the K hangs of one anchor differ (SplitSpec::hangs_per_anchor). Hang 0 is the
// anchor's hang as without K; hangs 1..K−1 each draw their own variation, seeded by
// their key, on top of the split's perturbation.
struct HangVariation {
  double grasp_miss = 0;       // m, σ per axis of a Gaussian grasp miss on the flat pattern
  double material_jitter = 0;  // fraction: each of the material's four values × (1 + U(−j, j)), per hang
  // rad/s: the flat garment starts turning about the grasp point at ω, each axis drawn
  // U(−w, w) (how a lift swings it before it hangs; 0: it starts at rest)
  double pickup_spin = 0;
  bool Any() const { return grasp_miss > 0 || material_jitter > 0 || pickup_spin > 0; }
};

struct SplitSpec {
  // "train" | "calibration" | "test" | "test_<rung>": test-split variants for the
  // ablation ladder of `drape eval --ladder`; they may use train instances (the
  // database entries themselves), their job keys start with "<name>/", and their
  // hangs use the seed of the key without that prefix (an unperturbed rung hangs
  // exactly like the database entry).
  std::string name;
  std::string sensing;  // key into Recipe::sensing ("database" | "sensed")
  std::vector<SplitSelector> selectors;
  Perturbation perturbation;
  int repeats = 1;  // perturbed repetitions per anchor (keys get "/p<r>" when > 1)
  // Also one unperturbed job per anchor, before its perturbed repeats (which then all
  // get "/p<r>"): its key, seeds and hang are those of the same anchor in a split
  // without perturbation, so e.g. a database can hold the exact anchors and grasps
  // offset from them. Needs a perturbation.
  bool unperturbed = false;
  // Every anchor hung K times (the database holds each anchor as a distribution of
  // hangs): hang 0 keyed as with K = 1, hangs k ≥ 1 keyed "/h<k>" and varied by
  // hang_variation (their hang seed differs too, so even without a variation they are
  // other draws of the fall).
  int hangs_per_anchor = 1;
  HangVariation hang_variation;
  // test only: the miss curve, grasp misses in metres (whole millimetres, ascending).
  // Each level becomes a ladder split "test_miss_<mm>mm" after test: the test split's
  // garments and perturbation with the grasp exactly that far from the anchor, in a
  // direction drawn from the anchor's key alone (the same at every level).
  std::vector<double> miss_curve;
  // >= 0 on a generated miss-curve split: its level (m); -1 otherwise.
  double miss_level = -1;
  void Validate() const;  // throws drape::FieldError
};

// "test_miss_<mm>mm", the name of the miss-curve split at `miss` metres.
std::string MissCurveSplitName(double miss);

// Sensing options of one kind of split, plus what the build keeps of it.
struct SensingSpec {
  SweepOptions sweep;
  bool keep_frames = false;  // store sweep/ (16-bit PNGs + cameras.json) in the entries
};
// What `sensing.database` starts from: SweepOptions' defaults with noise off
// (`sensing.sensed` starts from the parsed database spec with noise on).
SensingSpec DatabaseSensingDefaults();

struct Recipe {
  std::filesystem::path path;  // as given
  std::string file_label;      // what error messages call the file (path as given)
  std::string text;            // the full recipe text (dataset.json stores it)
  std::string name;
  std::string version;  // semantic version MAJOR.MINOR.PATCH
  uint64_t seed = 0;
  std::string description;
  std::string license = "CC-BY-4.0";
  bool allow_outside_paths = false;

  std::map<std::string, Material> materials;  // every material a garment may use, by name
  std::vector<GarmentSpec> garments;
  HangOptions hang;
  std::map<std::string, SensingSpec> sensing;  // "database", "sensed"
  FusionOptions fusion;
  FeatureOptions feature;
  std::vector<SplitSpec> splits;  // in order train, calibration, test (those present)

  std::vector<std::string> warnings;  // e.g. instances no split uses

  const GarmentSpec* FindGarment(const std::string& name) const;
};

// Parses and validates a recipe file. Throws drape::Error "FILE:LINE:COL: key: what".
Recipe LoadRecipe(const std::filesystem::path& path);
// Parses recipe text; relative paths resolve against `base_dir`. `file_label`
// names the file in error messages. `files` (a release's copies, Release::SourceFiles)
// maps each file path as written in the recipe to the file to read instead.
Recipe ParseRecipe(const std::string& text, const std::string& file_label, const std::filesystem::path& base_dir,
                   const std::map<std::string, std::filesystem::path>* files = nullptr);

// The recipe's keys for the documentation, from the parser's own tables
// (generator/recipe/keys.cpp): recipes/README.md's key tables are exactly
// RecipeKeysMarkdown of each section (keys_test.cpp checks).
using RecipeKeyDoc = OptionKeyDoc;
using RecipeSectionDoc = OptionSectionDoc;  // name: "simulation", "sensing", ...
std::vector<RecipeSectionDoc> RecipeKeyDocs();
std::string RecipeKeysMarkdown(const RecipeSectionDoc& section);

}  // namespace drape
