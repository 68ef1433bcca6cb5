// The files a mesh refers to: what assimp's own glTF/OBJ export writes beside the
// mesh, hand-written references (percent-encoding, texture options, data: URIs), and
// references leaving the mesh's folder as errors.
#include "garments/mesh_companions.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/files.h"
#include "common/testing.h"
#include "garments/io.h"
#include "garments/templates.h"

namespace drape {
namespace {

namespace fs = std::filesystem;
using Paths = std::vector<std::string>;

fs::path TempDir(const std::string& name) { return FreshTempDir("drape_mesh_companions_" + name); }

Garment Towel() {
  TemplateOptions o;
  o.edge_length = 0.1;
  return MakeGarment("towel", o);
}

TEST(MeshCompanions, GltfExportNamesItsBinAndTheMeshReadsBackWithIt) {
  const fs::path d = TempDir("gltf");
  ExportGarment(Towel(), d / "towel.gltf");
  const Paths c = MeshCompanions(d / "towel.gltf");
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(fs::path(c[0]).extension(), ".bin");
  EXPECT_TRUE(fs::exists(d / c[0]));
  // The .bin is really needed: without it the mesh does not read.
  EXPECT_GT(ReadMesh(d / "towel.gltf").V.rows(), 0);
  fs::remove(d / c[0]);
  EXPECT_THROW(ReadMesh(d / "towel.gltf"), Error);
}

TEST(MeshCompanions, ObjExportNamesItsMtl) {
  const fs::path d = TempDir("obj");
  ExportGarment(Towel(), d / "towel.obj");
  EXPECT_EQ(MeshCompanions(d / "towel.obj"), Paths{"towel.mtl"});
}

TEST(MeshCompanions, ObjMaterialsAndTexturesInSubfolders) {
  const fs::path d = TempDir("obj_tex");
  WriteFileAtomic(d / "m.obj", "mtllib mat/a.mtl missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  // Texture paths are relative to the .mtl; options come before the file name.
  WriteFileAtomic(d / "mat/a.mtl",
                  "newmtl cloth\nmap_Kd -s 1 1 1 tex/weave.png\nbump -bm 0.5 tex/bump.png\nMAP_KS tex/weave.png\n"
                  "map_d gone.png\n");
  WriteFileAtomic(d / "mat/tex/weave.png", "png");
  WriteFileAtomic(d / "mat/tex/bump.png", "png");
  EXPECT_EQ(MeshCompanions(d / "m.obj"), (Paths{"mat/a.mtl", "mat/tex/weave.png", "mat/tex/bump.png"}));
}

TEST(MeshCompanions, GltfUrisArePercentDecodedAndDataUrisSkipped) {
  const fs::path d = TempDir("gltf_uri");
  WriteFileAtomic(d / "g.gltf", R"({"asset": {"version": "2.0"},
    "buffers": [{"uri": "my%20data.bin", "byteLength": 4}, {"uri": "data:application/octet-stream;base64,AAAA"}],
    "images": [{"uri": "tex/a.png"}, {"uri": "https://example.org/b.png"}, {"bufferView": 0}]})");
  WriteFileAtomic(d / "my data.bin", "0000");
  WriteFileAtomic(d / "tex/a.png", "png");
  EXPECT_EQ(MeshCompanions(d / "g.gltf"), (Paths{"my data.bin", "tex/a.png"}));
}

TEST(MeshCompanions, ReferenceOutsideTheFolderIsAnError) {
  const fs::path d = TempDir("outside");
  WriteFileAtomic(d / "g.gltf", R"({"buffers": [{"uri": "../shared.bin"}]})");
  try {
    MeshCompanions(d / "g.gltf");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("g.gltf: refers to '../shared.bin', outside"), std::string::npos) << e.what();
  }
  WriteFileAtomic(d / "m.obj", "mtllib /etc/m.mtl\n");
  EXPECT_THROW(MeshCompanions(d / "m.obj"), Error);
  WriteFileAtomic(d / "bad.gltf", "{ not json");
  EXPECT_THROW(MeshCompanions(d / "bad.gltf"), Error);
}

TEST(MeshCompanions, FormatsWithoutReferencesHaveNone) {
  const fs::path d = TempDir("none");
  ExportGarment(Towel(), d / "towel.ply");
  ExportGarment(Towel(), d / "towel.glb");
  EXPECT_TRUE(MeshCompanions(d / "towel.ply").empty());
  EXPECT_TRUE(MeshCompanions(d / "towel.glb").empty());
}

}  // namespace
}  // namespace drape
