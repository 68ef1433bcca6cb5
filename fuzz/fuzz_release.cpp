// A release folder (generator/release): dataset.json, SHA256SUMS and catalog.sqlite
// split from one input at "\n--8<--\n" lines, then Release::Open and Verify.
#include "fuzz/fuzz_util.h"
#include "generator/release/release.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace drape;
  const auto parts = fuzz::SplitParts(fuzz::Bytes(data, size));
  const fs::path dir = fuzz::Scratch() / "release";
  fs::remove_all(dir);
  fs::create_directories(dir / "entries");
  const char* names[] = {"dataset.json", "SHA256SUMS", "catalog.sqlite"};
  for (size_t k = 0; k < 3; ++k) WriteFileAtomic(dir / names[k], k < parts.size() ? parts[k] : "");
  fuzz::ExpectOnlyDrapeErrors([&] { Release::Open(dir); });
  fuzz::ExpectOnlyDrapeErrors([&] { Verify(dir); });  // reports problems in its result
  return 0;
}
