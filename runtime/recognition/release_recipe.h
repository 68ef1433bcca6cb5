// The recipe a release records (dataset.json "recipe"), as the eval's split tables read
// it (`drape eval` parses it once and hands it to the miss curve's and the ladder's).
#pragma once

#include <optional>
#include <string>

#include "generator/recipe/recipe.h"
#include "generator/release/release.h"

namespace drape::recognition {

// The release's recipe, parsed from dataset.json; nullopt when the release records no
// recipe text.
std::optional<Recipe> ReleaseRecipe(const Release& release);

// A split's sensing and perturbation in words ("Kinect noise, grasp miss σ 10 mm per axis, ...").
std::string DescribeSplit(const SplitSpec& split);

}  // namespace drape::recognition
