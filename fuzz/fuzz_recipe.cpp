// Recipe YAML (generator/recipe): ParseRecipe on arbitrary text.
#include "fuzz/fuzz_util.h"
#include "generator/recipe/recipe.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(drape::fuzz::Bytes(data, size));
  drape::fuzz::ExpectOnlyDrapeErrors([&] { drape::ParseRecipe(text, "fuzz.yaml", drape::fuzz::Scratch()); });
  return 0;
}
