// Mesh decoding behind ReadMesh (garments/io.h), exposed for tests and fuzz targets.
//
// PLY and OBJ are read by drape's own parsers: they keep the file's vertex order, and
// they never abort on a file. assimp 5.2 is not trusted with them: its PLY header
// parser skips whitespace after `end_header`, so a binary body whose first byte is
// 0x09–0x0d or 0x20 (a float's low byte: about 1 file in 40) is read one byte off and
// its post-processing then aborts (TriangulateProcess assertion) or crashes; its OBJ
// importer numbers vertices by first use in the faces, not by the file's `v` lines.
// Other formats (glTF/GLB, STL, FBX, …) go through assimp with no post-processing
// step but its data-structure validation; node transforms, fan triangulation and
// the join of vertices at one position are done here.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "common/mesh.h"

namespace drape {

// Positions in file units, faces as triangles, uv empty or one per vertex.
struct MeshData {
  std::vector<Vec3> V;
  std::vector<Vec2> uv;
  std::vector<std::array<int, 3>> F;
};

// PLY: ascii, binary_little_endian or binary_big_endian; vertex x, y, z (+ s, t /
// u, v / texture_u, texture_v); face vertex_indices (or vertex_index) lists, polygons
// split as fans; other elements skipped. Throws drape::Error naming `where` and the
// element at fault.
MeshData ParsePly(std::string_view bytes, const std::string& where);

// OBJ: v, vt and f lines (1-based or negative indices, v/vt/vn forms), polygons split
// as fans; uv kept when each vertex has one texture coordinate throughout.
MeshData ParseObj(std::string_view text, const std::string& where);

// Any format assimp reads, from a file (glTF may reference companions) or from memory
// (`hint` is the extension without dot, e.g. "glb").
MeshData ReadWithAssimp(const std::filesystem::path& path);
MeshData ParseWithAssimp(std::string_view bytes, const std::string& hint, const std::string& where);

// Vertices at exactly the same position become one (the first keeps its index, later
// ones are dropped and indices above them shift down), so a file without repeated
// positions keeps its order. uv is dropped when merged vertices disagree on it.
void JoinIdenticalPositions(MeshData& mesh);

// Throws when a vertex is not finite or a face index is out of range.
void CheckMeshData(const MeshData& mesh, const std::string& where);

}  // namespace drape
