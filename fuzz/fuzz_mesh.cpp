// Mesh import (garments/mesh_read): drape's PLY and OBJ readers, and glTF (GLB) through
// assimp, chosen by the first input byte; then the checks and the join ReadMesh runs.
#include "fuzz/fuzz_util.h"
#include "garments/mesh_read.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace drape;
  const std::string_view in = fuzz::Bytes(data, size);
  fuzz::ExpectOnlyDrapeErrors([&] {
    MeshData m;
    if (in.rfind("ply", 0) == 0)
      m = ParsePly(in, "fuzz.ply");
    else if (in.rfind("glTF", 0) == 0)
      m = ParseWithAssimp(in, "glb", "fuzz.glb");
    else
      m = ParseObj(in, "fuzz.obj");
    CheckMeshData(m, "fuzz");
    JoinIdenticalPositions(m);
  });
  return 0;
}
