// feature.bin (generator/feature): DecodeFeature on arbitrary bytes.
#include "fuzz/fuzz_util.h"
#include "generator/feature/feature.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  drape::fuzz::ExpectOnlyDrapeErrors([&] { drape::DecodeFeature(drape::fuzz::Bytes(data, size), "feature.bin"); });
  return 0;
}
