// Garment files: meshes through assimp (OBJ, PLY, glTF/GLB, FBX, STL, … in; binary
// PLY, OBJ, glTF/GLB, STL out) and the anchors sidecar NAME.anchors.json.
//
// Sidecar format (written by ExportGarment; all forms below are accepted on import):
//   {"format": "drape-anchors-1", "mesh": "shirt.ply", "category": "long_sleeve_shirt",
//    "instance": "long_sleeve_shirt-M", "units": "metres",
//    "anchors": {"collar": {"vertex": 12, "position": [x, y, z], "uv": [u, v]}, ...}}
//   Each anchor may also be just a vertex index (`"collar": 12`) or a position
//   (`"collar": [x, y, z]`, snapped to the nearest vertex, in the mesh file's units).
//   The anchors object may be the whole file (`{"collar": 12, ...}`), or an array
//   `[{"label": "collar", "vertex": 12}, ...]`.
//   Vertex indices are the file's vertex order (PLY vertex element, OBJ `v` lines,
//   glTF accessors); only vertices at exactly the same position (STL, texture
//   seams) are merged, the first keeping its place. When an anchor
//   has both a vertex and a position that disagree, the position wins (and a warning
//   is reported), so sidecars survive a renumbering tool.
//
// Precision: assimp stores coordinates as float32, so a round trip reproduces every
// coordinate as (double)(float)x exactly (bit for bit); faces, anchor labels, vertex
// indices and uv are reproduced exactly. Needs layer_gap > 0: vertices at the same
// position are merged on import.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "garments/garment.h"

namespace drape {

struct ImportOptions {
  double unit_scale = 1;              // multiplies file coordinates (e.g. 0.01 for centimetres)
  std::string category = "custom";    // used unless the sidecar names one
  std::string instance;               // default: sidecar's instance, else the file stem
  double max_anchor_distance = 0.02;  // metres (after scaling) from the surface
  void Validate() const;
};

struct ImportReport {
  std::vector<std::string> warnings;
};

// Reads and validates a garment; throws drape::Error naming the file and the element
// at fault (vertex, face, edge, anchor). `anchors_json` may be empty (no anchors).
Garment ImportGarment(const std::filesystem::path& mesh, const std::filesystem::path& anchors_json,
                      const ImportOptions& options, ImportReport* report = nullptr);

// Writes the mesh (format from the extension: .ply binary, .obj (+ .mtl), .glb,
// .gltf (+ .bin), .stl binary) and AnchorsPath(out). Pattern uv goes into the texture
// coordinates (PLY s/t, OBJ vt, glTF TEXCOORD_0) when the garment has it.
void ExportGarment(const Garment& garment, const std::filesystem::path& out);

// out with its extension replaced by ".anchors.json" (shirt.ply → shirt.anchors.json).
std::filesystem::path AnchorsPath(const std::filesystem::path& mesh_path);

// Deterministic bytes of a mesh: "ply" (binary little-endian PLY), "obj", "glb", "stl".
// Same mesh → same bytes. `uv` (optional, #V×2) is written as texture coordinates.
std::string EncodeMesh(const TriMesh& mesh, std::string_view format = "ply", const Points2* uv = nullptr);

void WriteMesh(const TriMesh& mesh, const std::filesystem::path& path, const Points2* uv = nullptr);
// PLY and OBJ by drape's own readers, any other format assimp reads; polygons split
// as fans, vertices at one position joined, node transforms applied, all meshes of
// the scene merged, the file's vertex order kept (garments/mesh_read.h). Throws
// drape::Error naming the file; never aborts on a malformed file.
// `uv` (optional) receives the first texture coordinate set, or is left empty.
TriMesh ReadMesh(const std::filesystem::path& path, double unit_scale = 1, Points2* uv = nullptr);

// The sidecar JSON text for a garment (what ExportGarment writes).
std::string EncodeAnchors(const Garment& garment, const std::string& mesh_name);

}  // namespace drape
