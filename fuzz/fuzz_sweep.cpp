// A sweep folder (generator/sweep): cameras.json and the depth PNGs it names, split
// from one input at "\n--8<--\n" lines (part 0 cameras.json, part k frame k−1).
#include <cstdio>

#include "fuzz/fuzz_util.h"
#include "generator/sweep/sweep.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace drape;
  const auto parts = fuzz::SplitParts(fuzz::Bytes(data, size));
  const fs::path dir = fuzz::Scratch() / "sweep";
  fs::remove_all(dir);
  fs::create_directories(dir);
  WriteFileAtomic(dir / "cameras.json", parts[0]);
  for (size_t k = 1; k < parts.size() && k < 8; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", k - 1);
    WriteFileAtomic(dir / name, parts[k]);
  }
  fuzz::ExpectOnlyDrapeErrors([&] { ReadSweep(dir); });
  return 0;
}
