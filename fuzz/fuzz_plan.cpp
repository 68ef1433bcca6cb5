// Folding plan YAML (runtime/folding/plan): ParsePlan on arbitrary text.
#include "fuzz/fuzz_util.h"
#include "runtime/folding/plan.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(drape::fuzz::Bytes(data, size));
  drape::fuzz::ExpectOnlyDrapeErrors([&] { drape::folding::ParsePlan(text, "fuzz.yaml"); });
  return 0;
}
