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

#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "generator/recipe/recipe.h"

namespace drape::recipe_keys {

// The field a scalar key sets.
using OptionRef = std::variant<double*, int*, bool*, std::string*>;

template <typename O>
struct OptionKey {
  std::string key;                   // "a.b" = key b of the sub-map a
  std::function<OptionRef(O&)> ref;  // empty: parsed by hand in recipe.cpp (lists, names, files)
  std::string unit;
  std::string doc;
  std::string scope = "";  // garments: "templates" or "imports" when it applies to one kind only
};

// A member, or a member of a member: Ref(&SensingSpec::sweep, &SweepOptions::frames).
template <typename O, typename T, typename... M>
std::function<OptionRef(O&)> Ref(T O::*first, M... rest) {
  return [=](O& o) -> OptionRef { return &((o.*first).*....*rest); };
}

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
