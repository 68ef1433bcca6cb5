// The files a mesh file refers to and needs beside it, so that a release can carry them
// with its copy of the mesh (generator/release: PlanSources): a .gltf's (or .glb's)
// external buffers and images, an .obj's material libraries (mtllib) and the textures
// those name (map_Kd, bump, …). Without them a release moved to another machine could
// not re-read a .gltf whose geometry sits in a .bin.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace drape {

// Paths relative to the mesh's folder, '/'-separated, each once, in the order the files
// name them (an .mtl before the textures it names). Embedded data (data: URIs), URLs
// and files that do not exist are left out. A reference leaving the mesh's folder
// (absolute, or "../") throws drape::Error naming the file and the reference: a
// release could not keep it at the same place relative to its copy of the mesh. Other
// formats (PLY, STL, …) have none. A .gltf whose JSON does not parse throws.
std::vector<std::string> MeshCompanions(const std::filesystem::path& mesh);

}  // namespace drape
