// drape's own PLY/OBJ readers and the assimp path: crash reproducers, the file's vertex
// order, and malformed input as errors.
#include "garments/mesh_read.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <numeric>

#include "common/error.h"
#include "common/files.h"
#include "common/format.h"
#include "common/source_dir.h"
#include "common/testing.h"
#include "garments/io.h"
#include "garments/templates.h"

namespace fs = std::filesystem;

namespace drape {
namespace {

const fs::path kTestdata = SourceDir() / "garments" / "testdata";

fs::path TempDir(const std::string& name) { return FreshTempDir("drape_mesh_read_" + name); }

// Reference decoder for the one layout drape writes (float x, y, z; uchar-count int
// triangles), independent of the reader under test.
TriMesh DecodeDrapePly(const std::string& bytes) {
  const size_t body = bytes.find("end_header\n") + 11;
  int nv = 0, nf = 0;
  std::sscanf(bytes.c_str() + bytes.find("element vertex"), "element vertex %d", &nv);
  std::sscanf(bytes.c_str() + bytes.find("element face"), "element face %d", &nf);
  TriMesh m;
  m.V.resize(nv, 3);
  m.F.resize(nf, 3);
  for (int i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) {
      float x;
      std::memcpy(&x, bytes.data() + body + 12 * static_cast<size_t>(i) + 4 * static_cast<size_t>(k), 4);
      m.V(i, k) = x;
    }
  const size_t faces = body + 12 * static_cast<size_t>(nv);
  for (int f = 0; f < nf; ++f) {
    const size_t face = faces + 13 * static_cast<size_t>(f);
    EXPECT_EQ(bytes[face], 3);
    for (int k = 0; k < 3; ++k) std::memcpy(&m.F(f, k), bytes.data() + face + 1 + 4 * static_cast<size_t>(k), 4);
  }
  return m;
}

// Two meshes from a paper release on which assimp 5.2 aborted (TriangulateProcess
// assertion) and segfaulted: their binary body starts with byte 0x0a, which assimp's
// header parser swallowed as whitespace after end_header.
TEST(MeshRead, ReleaseFilesThatCrashedAssimpReadExactly) {
  for (const char* name : {"assimp-abort-hang.ply", "assimp-segv-recon.ply"}) {
    SCOPED_TRACE(name);
    const std::string bytes = ReadFile(kTestdata / name);
    EXPECT_EQ(bytes[bytes.find("end_header\n") + 11], '\n');
    const TriMesh want = DecodeDrapePly(bytes);
    const TriMesh got = ReadMesh(kTestdata / name);
    EXPECT_EQ(got.V, want.V);
    EXPECT_EQ(got.F, want.F);
  }
  EXPECT_EQ(ReadMesh(kTestdata / "assimp-abort-hang.ply").NumVertices(), 539);
  EXPECT_EQ(ReadMesh(kTestdata / "assimp-segv-recon.ply").NumFaces(), 117676);
}

// fuzz/fuzz_mesh found: a damaged .glb (an OBJ text behind the "glTF" magic) was
// declined by assimp's glTF loaders and then handed to its OBJ loader, which crashed
// (SEGV). Only the loaders of the file's extension may read it now.
TEST(MeshRead, DamagedGlbIsAnErrorNotACrash) {
  const std::string bytes = ReadFile(kTestdata / "assimp-crash-glb-as-obj.glb");
  EXPECT_CONTAINS(ErrorOf([&] { ParseWithAssimp(bytes, "glb", "x.glb"); }), "x.glb: cannot read mesh");
  EXPECT_CONTAINS(ErrorOf([&] { ReadMesh(kTestdata / "assimp-crash-glb-as-obj.glb"); }), "cannot read mesh");
  // A real GLB still reads, and assimp never reads what drape's own readers own.
  const fs::path d = TempDir("glb");
  TemplateOptions o;
  o.edge_length = 0.1;
  WriteMesh(MakeGarment("towel", o).mesh, d / "t.glb");
  EXPECT_GT(ReadMesh(d / "t.glb").NumVertices(), 0);
  // fuzz_mesh again: a chunk length of ~4 GB made assimp allocate it (out of memory).
  const std::string oom = ReadFile(kTestdata / "assimp-oom-glb-chunk.glb");
  EXPECT_CONTAINS(ErrorOf([&] { ParseWithAssimp(oom, "glb", "x.glb"); }), "damaged GLB: chunk at byte 12 beyond");
  const std::string glb = ReadFile(d / "t.glb");
  EXPECT_CONTAINS(ErrorOf([&] { ParseWithAssimp(glb.substr(0, glb.size() - 1), "glb", "x.glb"); }),
                  "damaged GLB: header length");
  EXPECT_CONTAINS(ErrorOf([&] { ParseWithAssimp("ply\n", "ply", "x.ply"); }), "no reader for '.ply' files");
  EXPECT_CONTAINS(ErrorOf([&] { ParseWithAssimp("v 0 0 0\n", "xyz123", "x"); }), "no reader for '.xyz123' files");
}

// Any byte after end_header reads the same: a mesh whose first x coordinate starts
// with each possible low byte round-trips through EncodeMesh → ReadMesh.
TEST(MeshRead, EveryFirstBodyByteRoundTrips) {
  const fs::path dir = TempDir("first_byte");
  TriMesh m = MakeGarment("towel", {}).mesh;
  m.V = m.V.cast<float>().cast<double>();  // PLY stores float32
  for (int b = 0; b < 256; ++b) {
    float x = static_cast<float>(m.V(0, 0));
    uint32_t u;
    std::memcpy(&u, &x, 4);
    u = (u & ~0xffu) | static_cast<uint32_t>(b);
    std::memcpy(&x, &u, 4);
    m.V(0, 0) = x;
    WriteFileAtomic(dir / "m.ply", EncodeMesh(m));
    const TriMesh r = ReadMesh(dir / "m.ply");
    ASSERT_EQ(r.V, m.V) << "first byte " << b;
    ASSERT_EQ(r.F, m.F) << "first byte " << b;
  }
}

// A garment whose file numbers vertices differently from first use in the faces:
// reversed order. Anchors give both vertex and position; both must agree on import.
TriMesh Reversed(const TriMesh& m, std::vector<int>* new_of_old) {
  const int n = m.NumVertices();
  TriMesh r;
  r.V = m.V.colwise().reverse();
  new_of_old->resize(n);
  for (int i = 0; i < n; ++i) (*new_of_old)[i] = n - 1 - i;
  r.F = m.F;
  for (int f = 0; f < m.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) r.F(f, k) = (*new_of_old)[m.F(f, k)];
  return r;
}

std::string ObjText(const TriMesh& m) {
  std::string s = "# vertices in file order, faces after\n";
  char buf[160];
  for (int i = 0; i < m.NumVertices(); ++i) {
    std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", m.V(i, 0), m.V(i, 1), m.V(i, 2));
    s += buf;
  }
  for (int f = 0; f < m.NumFaces(); ++f) {
    std::snprintf(buf, sizeof buf, "f %d/%d %d/%d %d/%d\n", m.F(f, 0) + 1, m.F(f, 0) + 1, m.F(f, 1) + 1, m.F(f, 1) + 1,
                  m.F(f, 2) + 1, m.F(f, 2) + 1);
    s += buf;
  }
  for (int i = 0; i < m.NumVertices(); ++i) {
    std::snprintf(buf, sizeof buf, "vt %d 0.5\n", i);
    s += buf;
  }
  return s;
}

std::string AsciiPly(const TriMesh& m) {
  std::string s = "ply\r\nformat ascii 1.0\r\ncomment hand written\r\nelement vertex " +
                  std::to_string(m.NumVertices()) +
                  "\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\nelement face " +
                  std::to_string(m.NumFaces()) + "\r\nproperty list uchar uint vertex_indices\r\nend_header\r\n";
  char buf[160];
  for (int i = 0; i < m.NumVertices(); ++i) {
    std::snprintf(buf, sizeof buf, "%.17g %.17g %.17g\n", m.V(i, 0), m.V(i, 1), m.V(i, 2));
    s += buf;
  }
  for (int f = 0; f < m.NumFaces(); ++f)
    s += "3 " + std::to_string(m.F(f, 0)) + " " + std::to_string(m.F(f, 1)) + " " + std::to_string(m.F(f, 2)) + "\n";
  return s;
}

TEST(MeshRead, ImportKeepsTheFilesVertexOrder) {
  const fs::path dir = TempDir("order");
  const Garment g = MakeGarment("skirt", {});
  std::vector<int> map;
  const TriMesh r = Reversed(g.mesh, &map);
  std::string anchors = "{";
  for (const Anchor& a : g.anchors) {
    const int v = map[a.vertex];
    char buf[200];
    std::snprintf(buf, sizeof buf, "%s\"%s\": {\"vertex\": %d, \"position\": [%.9g, %.9g, %.9g]}",
                  anchors.size() > 1 ? ", " : "", a.label.c_str(), v, r.V(v, 0), r.V(v, 1), r.V(v, 2));
    anchors += buf;
  }
  anchors += "}";
  std::ofstream(dir / "g.anchors.json") << anchors;
  std::ofstream(dir / "g.obj") << ObjText(r);
  std::ofstream(dir / "g.ply", std::ios::binary) << AsciiPly(r);
  WriteFileAtomic(dir / "g.glb", EncodeMesh(r, "glb"));
  for (const char* ext : {"obj", "ply", "glb"}) {
    SCOPED_TRACE(ext);
    ImportReport report;
    const Garment h = ImportGarment(dir / (std::string("g.") + ext), dir / "g.anchors.json", {}, &report);
    EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
    ASSERT_EQ(h.mesh.NumVertices(), r.NumVertices());
    EXPECT_EQ(h.mesh.F, r.F);
    EXPECT_LT((h.mesh.V - r.V).cwiseAbs().maxCoeff(), 1e-6);
    for (size_t i = 0; i < g.anchors.size(); ++i) EXPECT_EQ(h.anchors[i].vertex, map[g.anchors[i].vertex]);
    if (std::string(ext) == "obj") {
      ASSERT_EQ(h.uv.rows(), r.NumVertices());  // vt i belongs to v i throughout
      for (int i = 0; i < r.NumVertices(); ++i) EXPECT_EQ(h.uv(i, 0), i);
    }
  }
}

TEST(MeshRead, PlyFormsAndPolygons) {
  // Big-endian binary with a quad, an extra property and an extra element.
  std::string b =
      "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  auto be32 = [&](uint32_t u) {
    for (int k = 3; k >= 0; --k) b.push_back(static_cast<char>((u >> (8 * k)) & 0xff));
  };
  auto bef = [&](float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    be32(u);
  };
  const float xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (auto& p : xy) bef(p[0]), bef(p[1]), bef(0), b.push_back('\x7f');
  b.push_back(4);
  for (uint32_t i = 0; i < 4; ++i) be32(i);
  be32(0), be32(1);
  const MeshData m = ParsePly(b, "q.ply");
  ASSERT_EQ(m.V.size(), 4u);
  EXPECT_EQ(m.V[2], Vec3(1, 1, 0));
  ASSERT_EQ(m.F.size(), 2u);
  EXPECT_EQ(m.F[1], (std::array<int, 3>{0, 2, 3}));
  // Truncated: every prefix of the body fails cleanly.
  for (size_t cut = b.size() - 1; cut > b.find("end_header"); --cut)
    EXPECT_CONTAINS(ErrorOf([&] { ParsePly(b.substr(0, cut), "q.ply"); }), "q.ply");
}

TEST(MeshRead, MalformedFilesAreErrorsNamingTheFile) {
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n";
  auto check = [&](const std::string& text, const std::string& part) {
    const std::string e = ErrorOf([&] {
      MeshData m = ParsePly(text, "x.ply");
      CheckMeshData(m, "x.ply");
    });
    EXPECT_CONTAINS(e, "x.ply");
    EXPECT_CONTAINS(e, part);
  };
  check(head + "3 0 1 7\n", "face 0 names vertex 7");
  check(head + "2 0 1\n", "face 0: has 2 vertex indices");
  check(head + "3 0 1 -1\n", "is not a valid index");
  check(head + "3 0 1\n", "ends early");
  check(head + "3 0 1 x\n", "'x' is not a number");
  // ASCII list lengths that no integer holds (casting them was undefined behaviour).
  check(head + "nan 0 1 2\n", "face 0: list length nan is not possible");
  check(head + "1e300 0 1 2\n", "face 0: list length 1e+300 is not possible");
  check("ply\nformat ascii 1.0\nelement vertex 99999999\nproperty float x\nend_header\n1\n", "ends early");
  check("ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n", "no end_header");
  check("ply\nformat weird 1.0\nend_header\n", "unknown PLY format");
  check("ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar x\nend_header\n", "cannot read property");
  auto obj = [&](const std::string& text, const std::string& part) {
    const std::string e = ErrorOf([&] {
      MeshData m = ParseObj(text, "x.obj");
      CheckMeshData(m, "x.obj");
    });
    EXPECT_CONTAINS(e, "x.obj");
    EXPECT_CONTAINS(e, part);
  };
  obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "face 0 names vertex 3");
  obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "x.obj:4: bad index '0'");
  obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "x.obj:4: index -4 is out of range");
  obj("v 0 0\n", "x.obj:1: 'v' needs 3 numbers");
  obj("v 0 0 zero\n", "'zero' is not a number");
  obj("v 0 0 0\nv 1 0 0\nf 1 2\n", "x.obj:3: a face needs at least 3 vertices");
  // Negative (relative) indices and v/vt/vn forms.
  const MeshData m = ParseObj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf -3/1/1 -2//1 -1\n", "x.obj");
  ASSERT_EQ(m.F.size(), 1u);
  EXPECT_EQ(m.F[0], (std::array<int, 3>{0, 1, 2}));
  EXPECT_TRUE(m.uv.empty());  // not every corner has a texture coordinate
}

TEST(MeshRead, JoinKeepsFirstOccurrencesInOrder) {
  MeshData m;
  m.V = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(1, 0, 0)};
  m.uv = {Vec2(0, 0), Vec2(1, 0), Vec2(0, 0), Vec2(0, 1), Vec2(1, 0)};
  m.F = {{2, 4, 3}};
  JoinIdenticalPositions(m);
  ASSERT_EQ(m.V.size(), 3u);
  EXPECT_EQ(m.V[2], Vec3(0, 1, 0));
  EXPECT_EQ(m.F[0], (std::array<int, 3>{0, 1, 2}));
  EXPECT_EQ(m.uv.size(), 3u);  // joined vertices agree on uv
  m.V.push_back(Vec3(0, 1, 0));
  m.uv.push_back(Vec2(9, 9));
  JoinIdenticalPositions(m);
  EXPECT_TRUE(m.uv.empty());  // a seam: uv dropped
  // -0 and 0 are one position (==), though their bits differ.
  m.V = {Vec3(0, -0.0, 1), Vec3(2, 0, 0), Vec3(0, 0, 1)};
  m.F = {{0, 1, 2}};
  JoinIdenticalPositions(m);
  ASSERT_EQ(m.V.size(), 2u);
  EXPECT_EQ(m.F[0], (std::array<int, 3>{0, 1, 0}));
  // No repeats among many distinct positions (the hash's probe chains): untouched.
  m.V.clear();
  for (int i = 0; i < 5000; ++i) m.V.emplace_back(i % 7, (i / 7) % 11, i / 77);
  m.F = {{4999, 0, 1}};
  const MeshData before = m;
  JoinIdenticalPositions(m);
  EXPECT_EQ(m.V, before.V);
  EXPECT_EQ(m.F, before.F);
}

// The binary fast paths (fixed-size vertex records, triangles read in place) give what
// the ASCII reader gives for the same values: extra vertex properties, uint indices,
// a quad between triangles (back to the general path mid-element).
TEST(MeshRead, BinaryFastPathsMatchTheAsciiReader) {
  const std::string head =
      "element vertex 5\nproperty double x\nproperty uchar red\nproperty float y\nproperty float z\n"
      "element face 3\nproperty list uchar uint vertex_indices\nend_header\n";
  const double xyz[5][3] = {{0.1, 0, 0}, {1, 0.25, 0}, {1, 1, -0.5}, {0, 1, 2}, {0.5, 0.5, 0.5}};
  const std::vector<std::vector<uint32_t>> faces = {{0, 1, 2}, {0, 2, 3, 4}, {4, 3, 1}};
  std::string bin = "ply\nformat binary_little_endian 1.0\n" + head, ascii = "ply\nformat ascii 1.0\n" + head;
  auto put = [&](const auto& v) { bin.append(reinterpret_cast<const char*>(&v), sizeof v); };
  for (const auto& p : xyz) {
    put(p[0]), put(uint8_t{7}), put(float(p[1])), put(float(p[2]));
    ascii += FormatNumber(p[0]) + " 7 " + FormatNumber(p[1]) + " " + FormatNumber(p[2]) + "\n";
  }
  for (const auto& f : faces) {
    put(uint8_t(f.size()));
    ascii += std::to_string(f.size());
    // Appended, not " " + std::to_string(i): gcc 12 -O3 reports a bogus -Wrestrict
    // inside libstdc++ when a string is built from a one-character literal (gcc bug 105329).
    for (uint32_t i : f) put(i), ascii += ' ', ascii += std::to_string(i);
    ascii += "\n";
  }
  const MeshData a = ParsePly(bin, "b.ply"), b = ParsePly(ascii, "a.ply");
  EXPECT_EQ(a.V, b.V);
  EXPECT_EQ(a.F, b.F);
  ASSERT_EQ(a.F.size(), 4u);
  EXPECT_EQ(a.F[3], (std::array<int, 3>{4, 3, 1}));
  // An index beyond int's range and a truncated triangle are errors naming the face.
  std::string big = bin;
  big[big.size() - 1] = '\x80';  // the last index's high byte
  EXPECT_CONTAINS(ErrorOf([&] { ParsePly(big, "b.ply"); }), "b.ply: face 2: vertex index");
  EXPECT_CONTAINS(ErrorOf([&] { ParsePly(bin.substr(0, bin.size() - 2), "b.ply"); }), "ends early");
}

}  // namespace
}  // namespace drape
