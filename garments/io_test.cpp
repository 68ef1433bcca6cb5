// Export → import round trips, deterministic encoding, and every bad-input case.
#include "garments/io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include "common/error.h"
#include "common/files.h"
#include "common/testing.h"
#include "garments/preview.h"
#include "garments/templates.h"
#include "garments/validate.h"

namespace fs = std::filesystem;

namespace drape {
namespace {

fs::path TempDir(const std::string& name) { return FreshTempDir("drape_garments_io_" + name); }

void Write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

double F32(double x) { return static_cast<double>(static_cast<float>(x)); }

class RoundTrip : public ::testing::TestWithParam<std::string> {};

// "Exactly": coordinates equal their float32 rounding bit for bit (assimp stores
// float32); faces, anchor labels/vertices/uv and category/instance are identical.
TEST_P(RoundTrip, PreservesVerticesFacesAndAnchors) {
  const std::string ext = GetParam();
  const fs::path dir = TempDir("rt_" + ext);
  for (const char* name : {"long_sleeve_shirt", "pants", "towel"}) {
    SCOPED_TRACE(name);
    TemplateOptions opt;
    opt.seed = 5;
    const Garment g = MakeGarment(name, opt);
    const fs::path out = dir / (std::string(name) + "." + ext);
    ExportGarment(g, out);
    ASSERT_TRUE(fs::exists(AnchorsPath(out)));
    EXPECT_EQ(AnchorsPath(out).filename().string(), std::string(name) + ".anchors.json");
    ImportReport report;
    const Garment h = ImportGarment(out, AnchorsPath(out), {}, &report);
    EXPECT_TRUE(report.warnings.empty());
    ASSERT_EQ(h.mesh.NumVertices(), g.mesh.NumVertices());
    ASSERT_EQ(h.mesh.NumFaces(), g.mesh.NumFaces());
    for (int v = 0; v < g.mesh.NumVertices(); ++v)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(h.mesh.V(v, k), F32(g.mesh.V(v, k))) << "vertex " << v;
    EXPECT_EQ(h.mesh.F, g.mesh.F);
    // Every format here stores texture coordinates; glTF flips v (v → 1 − v) on the
    // way out and in, which costs float32 round-off, so uv is exact for PLY/OBJ only.
    ASSERT_EQ(h.uv.rows(), g.uv.rows());
    const bool gltf = ext == "glb" || ext == "gltf";
    for (int v = 0; v < g.uv.rows(); ++v)
      for (int k = 0; k < 2; ++k) {
        if (gltf) {
          ASSERT_NEAR(h.uv(v, k), g.uv(v, k), 2e-7);
        } else {
          ASSERT_EQ(h.uv(v, k), F32(g.uv(v, k)));
        }
      }
    EXPECT_EQ(h.category, g.category);
    EXPECT_EQ(h.instance, g.instance);
    ASSERT_EQ(h.anchors.size(), g.anchors.size());
    for (size_t i = 0; i < g.anchors.size(); ++i) {
      EXPECT_EQ(h.anchors[i].label, g.anchors[i].label);
      EXPECT_EQ(h.anchors[i].vertex, g.anchors[i].vertex);
      EXPECT_EQ(h.anchors[i].uv, g.anchors[i].uv);
      EXPECT_EQ(h.anchors[i].position, Vec3(h.mesh.V.row(h.anchors[i].vertex)));
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, RoundTrip, ::testing::Values("ply", "obj", "glb", "gltf"));

TEST(Io, StlLosesOrderButAnchorsFollowTheirPositions) {
  const fs::path dir = TempDir("stl");
  const Garment g = MakeGarment("shorts", {});
  ExportGarment(g, dir / "s.stl");
  ImportReport report;
  const Garment h = ImportGarment(dir / "s.stl", dir / "s.anchors.json", {}, &report);
  EXPECT_EQ(h.mesh.NumVertices(), g.mesh.NumVertices());  // welded despite per-face normals
  EXPECT_EQ(InspectMesh(h.mesh).components, 1);
  for (size_t i = 0; i < g.anchors.size(); ++i) {
    EXPECT_EQ(h.anchors[i].label, g.anchors[i].label);
    EXPECT_LT((h.anchors[i].position - g.anchors[i].position).norm(), 1e-6) << g.anchors[i].label;
  }
}

TEST(Io, EncodeMeshIsDeterministicAndReadable) {
  TemplateOptions opt;
  opt.seed = 11;
  const Garment g = MakeGarment("tshirt", opt);
  const std::string a = EncodeMesh(g.mesh), b = EncodeMesh(MakeGarment("tshirt", opt).mesh);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  const fs::path dir = TempDir("encode");
  WriteFileAtomic(dir / "m.ply", a);
  const TriMesh m = ReadMesh(dir / "m.ply");
  EXPECT_EQ(m.F, g.mesh.F);
  EXPECT_EQ(m.NumVertices(), g.mesh.NumVertices());
  // A different seed gives different bytes.
  opt.seed = 12;
  EXPECT_NE(a, EncodeMesh(MakeGarment("tshirt", opt).mesh));
  for (const char* f : {"obj", "glb", "stl"}) EXPECT_EQ(EncodeMesh(g.mesh, f), EncodeMesh(g.mesh, f)) << f;
  EXPECT_CONTAINS(ErrorOf([&] { EncodeMesh(g.mesh, "xyz"); }), "xyz");
}

// A unit square in the x–y plane as two triangles (OBJ), plus extras.
const char* kSquare = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";

TEST(Io, SidecarFormsAndUnitScale) {
  const fs::path dir = TempDir("sidecar");
  Write(dir / "sq.obj", kSquare);
  Write(dir / "a.json", R"({"corner": 0, "far_corner": [1, 1.4, 0], "mid": {"vertex": 1, "uv": [1, 0]}})");
  ImportOptions opt;
  opt.unit_scale = 0.01;  // the file is in centimetres
  const Garment g = ImportGarment(dir / "sq.obj", dir / "a.json", opt);
  EXPECT_NEAR(g.mesh.V(2, 0), 0.01, 1e-9);
  ASSERT_EQ(g.anchors.size(), 3u);
  EXPECT_EQ(g.anchors[0].vertex, 0);
  EXPECT_EQ(g.anchors[1].vertex, 2);  // snapped: 4 mm off the corner
  EXPECT_EQ(g.anchors[2].uv, Vec2(1, 0));
  EXPECT_EQ(g.instance, "sq");
  EXPECT_EQ(g.category, "custom");
  Write(dir / "b.json", R"({"anchors": [{"label": "x", "vertex": 3}, {"label": "y", "position": [0, 0, 0]}]})");
  const Garment h = ImportGarment(dir / "sq.obj", dir / "b.json", {});
  EXPECT_EQ(h.anchors[0].vertex, 3);
  EXPECT_EQ(h.anchors[1].vertex, 0);
}

TEST(Io, BadInputsNameFileAndElement) {
  const fs::path dir = TempDir("bad");
  const std::string d = dir.string();
  // Unreadable.
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "missing.ply", {}, {}); }), d + "/missing.ply: no such file");
  Write(dir / "junk.ply", "this is not a mesh\n");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "junk.ply", {}, {}); }), d + "/junk.ply: cannot read mesh");
  // No triangles (only a polyline).
  Write(dir / "lines.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2 3\n");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "lines.obj", {}, {}); }), d + "/lines.obj: no triangles");
  // Non-finite coordinate (ASCII PLY).
  Write(dir / "nan.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "nan.ply", {}, {}); }), d + "/nan.ply: vertex 2 has a non-finite");
  Write(dir / "inf.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\ninf 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "inf.ply", {}, {}); }), d + "/inf.ply: vertex 1 has a non-finite");
  // Degenerate face (collinear corners).
  Write(dir / "degen.obj", std::string(kSquare) + "v 2 0 0\nf 1 2 5\n");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "degen.obj", {}, {}); }), d + "/degen.obj: face 2 (");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "degen.obj", {}, {}); }), "is degenerate");
  // Non-manifold edge: three triangles on edge 1–3.
  Write(dir / "fin.obj", std::string(kSquare) + "v 0.5 0.5 1\nf 1 3 5\n");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "fin.obj", {}, {}); }),
                  d + "/fin.obj: edge (0, 2) is shared by more than two faces");
  // Anchors.
  Write(dir / "sq.obj", kSquare);
  Write(dir / "missing_vertex.json", R"({"left_elbow": 99})");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", dir / "missing_vertex.json", {}); }),
                  d + "/missing_vertex.json: anchor 'left_elbow': vertex 99 does not exist");
  Write(dir / "far.json", R"({"collar": [0.5, 0.5, 0.3]})");
  const std::string far = ErrorOf([&] { ImportGarment(dir / "sq.obj", dir / "far.json", {}); });
  EXPECT_CONTAINS(far, d + "/far.json: anchor 'collar': position [0.5, 0.5, 0.3] is 0.3 m from the surface");
  Write(dir / "dup.json", R"({"collar": 0, "collar": 1})");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", dir / "dup.json", {}); }),
                  d + "/dup.json: duplicate anchor label 'collar'");
  Write(dir / "dup2.json", R"({"anchors": [{"label": "a", "vertex": 0}, {"label": "a", "vertex": 1}]})");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", dir / "dup2.json", {}); }),
                  d + "/dup2.json: duplicate anchor label 'a'");
  Write(dir / "broken.json", R"({"collar": )");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", dir / "broken.json", {}); }),
                  d + "/broken.json: invalid JSON");
  Write(dir / "float_index.json", R"({"collar": 1.5})");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", dir / "float_index.json", {}); }),
                  "anchor 'collar': vertex must be an integer");
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", dir / "nope.json", {}); }), "nope.json");
  ImportOptions bad;
  bad.unit_scale = 0;
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", {}, bad); }), "unit_scale");
  bad.unit_scale = 2e6;  // the cap the recipe had before ranges moved into Validate()
  EXPECT_CONTAINS(ErrorOf([&] { ImportGarment(dir / "sq.obj", {}, bad); }), "unit_scale: must be in (0, 1e6]");
}

TEST(Validate, InMemoryGarmentProblemsAreNamed) {
  Garment g = MakeGarment("shorts", {});
  EXPECT_TRUE(CheckGarment(g, "g").empty());
  auto first = [](const Garment& x) {
    const auto p = CheckGarment(x, "g");
    return p.empty() ? std::string() : p.front();
  };
  Garment a = g;
  a.mesh.V(5, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_CONTAINS(first(a), "g: vertex 5 has a non-finite coordinate");
  a = g;
  a.mesh.F(3, 1) = a.mesh.F(3, 0);
  EXPECT_CONTAINS(first(a), "g: face 3 (");
  a = g;
  a.anchors[2].vertex = 1 << 20;
  EXPECT_CONTAINS(first(a), "anchor '" + g.anchors[2].label + "' names vertex 1048576");
  a = g;
  a.anchors[1].label = a.anchors[0].label;
  EXPECT_CONTAINS(first(a), "duplicate anchor label '" + g.anchors[0].label + "'");
  a = g;
  a.anchors[0].position += Vec3(0, 0, 0.5);
  EXPECT_CONTAINS(first(a), "from the surface");
  a = g;
  a.mesh.F.conservativeResize(a.mesh.NumFaces() + 1, 3);
  a.mesh.F.row(a.mesh.NumFaces() - 1) = g.mesh.F.row(0);
  EXPECT_CONTAINS(first(a), "is shared by more than two faces");
  a = g;
  a.mesh.F.resize(0, 3);
  EXPECT_CONTAINS(first(a), "g: no triangles");
  EXPECT_THROW(ValidateGarment(a, "g"), Error);
}

TEST(Preview, IsAPngOfTheRequestedWidthAndDeterministic) {
  const Garment g = MakeGarment("long_sleeve_shirt", {});
  const std::string png = RenderFlatPreview(g, 640);
  ASSERT_GT(png.size(), 24u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  // IHDR width, big-endian at byte 16.
  const auto* u = reinterpret_cast<const unsigned char*>(png.data());
  EXPECT_EQ((u[16] << 24) | (u[17] << 16) | (u[18] << 8) | u[19], 640);
  EXPECT_EQ(png, RenderFlatPreview(g, 640));
  EXPECT_THROW(RenderFlatPreview(g, 10), Error);
  // Imported garments (no uv, no layers) render too.
  Garment bare = g;
  bare.uv.resize(0, 2);
  bare.layer.clear();
  EXPECT_GT(RenderFlatPreview(bare).size(), 1000u);
}

}  // namespace
}  // namespace drape
