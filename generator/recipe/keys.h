// The recipe's key tables (internal to generator/recipe). Every key of every recipe
// section is written once, in keys.cpp: its name, the options field it sets, its unit
// and its meaning. From these the parser knows which keys are allowed where, reads
// the scalar ones into the stage's Options struct, maps a Validate() FieldError back to
// the key that set the field, and recipes/README.md's tables are generated
// (RecipeKeyDocs; keys_test.cpp fails when the README disagrees).
//
// Ranges are deliberately absent: each Options struct's Validate() owns them.
//
// To add a key: add a row to the section's table (and the field, its default and
// its range check to the Options struct), then paste the table the test prints
// into recipes/README.md.
#pragma once

#include <vector>

#include "common/yaml_keys.h"
#include "generator/recipe/recipe.h"

namespace drape::recipe_keys {

// The key-table vocabulary is common/yaml_keys.h's, shared with the --config options file.
using drape::OptionKey;
using drape::OptionRef;
using drape::Ref;

const std::vector<OptionKey<Recipe>>& TopKeys();
const std::vector<OptionKey<Material>>& MaterialKeys();
const std::vector<OptionKey<GarmentSpec>>& GarmentKeys();
const std::vector<OptionKey<HangOptions>>& SimulationKeys();
const std::vector<OptionKey<SensingSpec>>& SensingKeys();
const std::vector<OptionKey<FusionOptions>>& FusionKeys();
const std::vector<OptionKey<FeatureOptions>>& FeatureKeys();
const std::vector<OptionKey<SplitSpec>>& SplitKeys();
const std::vector<OptionKey<SplitSelector>>& SelectorKeys();
const std::vector<OptionKey<Perturbation>>& PerturbationKeys();

}  // namespace drape::recipe_keys
