// Anchors sidecar JSON (garments/io): ImportGarment of a fixed small garment with the
// input as its NAME.anchors.json.
#include "fuzz/fuzz_util.h"
#include "garments/io.h"
#include "garments/templates.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace drape;
  static const fs::path mesh = [] {
    TemplateOptions o;
    o.edge_length = 0.08;
    const fs::path p = fuzz::Scratch() / "towel.ply";
    WriteMesh(MakeGarment("towel", o).mesh, p);
    return p;
  }();
  const fs::path anchors = fuzz::Scratch() / "towel.anchors.json";
  WriteFileAtomic(anchors, fuzz::Bytes(data, size));
  fuzz::ExpectOnlyDrapeErrors([&] { ImportGarment(mesh, anchors, {}); });
  return 0;
}
