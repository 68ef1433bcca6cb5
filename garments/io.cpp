#include "garments/io.h"

#include <assimp/config.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Exporter.hpp>
#include <cmath>
#include <fstream>
#include <limits>
#include <memory>
#include <set>
#include <sstream>

#include "common/error.h"
#include "common/field_error.h"
#include "common/files.h"
#include "common/format.h"
#include "common/json.h"
#include "garments/mesh_read.h"
#include "garments/validate.h"

namespace fs = std::filesystem;

namespace drape {
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Assimp exporter id for a format name or file extension.
std::string ExporterId(std::string_view format, const std::string& where) {
  const std::string f = Lower(std::string(format));
  if (f == "ply" || f == ".ply") return "plyb";
  if (f == "obj" || f == ".obj") return "obj";
  if (f == "glb" || f == ".glb") return "glb2";
  if (f == "gltf" || f == ".gltf") return "gltf2";
  if (f == "stl" || f == ".stl") return "stlb";
  throw Error(where + ": unsupported mesh format '" + std::string(format) + "' (use .ply, .obj, .glb, .gltf or .stl)");
}

// A one-mesh aiScene owning copies of V, F (and uv). The aiScene destructor frees it.
std::unique_ptr<aiScene> MakeScene(const TriMesh& mesh, const Points2* uv) {
  auto scene = std::make_unique<aiScene>();
  scene->mRootNode = new aiNode();
  scene->mRootNode->mName = "garment";
  scene->mRootNode->mMeshes = new unsigned int[1]{0};
  scene->mRootNode->mNumMeshes = 1;
  scene->mMaterials = new aiMaterial* [1] { new aiMaterial() };
  scene->mNumMaterials = 1;
  auto* m = new aiMesh();
  scene->mMeshes = new aiMesh* [1] { m };
  scene->mNumMeshes = 1;
  m->mName = "garment";
  m->mMaterialIndex = 0;
  m->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  const unsigned nv = static_cast<unsigned>(mesh.NumVertices());
  m->mNumVertices = nv;
  m->mVertices = new aiVector3D[nv];
  for (unsigned i = 0; i < nv; ++i)
    m->mVertices[i] = aiVector3D(static_cast<ai_real>(mesh.V(i, 0)), static_cast<ai_real>(mesh.V(i, 1)),
                                 static_cast<ai_real>(mesh.V(i, 2)));
  if (uv && uv->rows() == mesh.NumVertices()) {
    m->mTextureCoords[0] = new aiVector3D[nv];
    m->mNumUVComponents[0] = 2;
    for (unsigned i = 0; i < nv; ++i)
      m->mTextureCoords[0][i] = aiVector3D(static_cast<ai_real>((*uv)(i, 0)), static_cast<ai_real>((*uv)(i, 1)), 0);
  }
  const unsigned nf = static_cast<unsigned>(mesh.NumFaces());
  m->mNumFaces = nf;
  m->mFaces = new aiFace[nf];
  for (unsigned f = 0; f < nf; ++f) {
    m->mFaces[f].mNumIndices = 3;
    m->mFaces[f].mIndices = new unsigned int[3];
    for (int k = 0; k < 3; ++k) m->mFaces[f].mIndices[k] = static_cast<unsigned>(mesh.F(f, k));
  }
  return scene;
}

std::string Where(const fs::path& p) { return p.string(); }

// Parses JSON, recording duplicate object keys (nlohmann would silently keep one).
Json ParseJsonStrict(const std::string& text, const std::string& where) {
  std::vector<std::set<std::string>> keys;
  std::string duplicate;
  Json::parser_callback_t cb = [&](int, Json::parse_event_t ev, Json& parsed) {
    if (ev == Json::parse_event_t::object_start) keys.emplace_back();
    if (ev == Json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
    if (ev == Json::parse_event_t::key && !keys.empty() && parsed.is_string()) {
      if (!keys.back().insert(parsed.get<std::string>()).second && duplicate.empty())
        duplicate = parsed.get<std::string>();
    }
    return true;
  };
  Json j;
  try {
    j = Json::parse(text, cb);
  } catch (const Json::exception& e) {
    throw Error(where + ": invalid JSON: " + e.what());
  }
  if (!duplicate.empty())
    throw Error(where + ": duplicate anchor label '" + duplicate + "' (each key may appear once)");
  return j;
}

int NearestVertex(const TriMesh& mesh, const Vec3& p) {
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (int i = 0; i < mesh.NumVertices(); ++i) {
    const double d = (Vec3(mesh.V.row(i)) - p).squaredNorm();
    if (d < best_d) best_d = d, best = i;
  }
  return best;
}

std::string FmtVec(const Vec3& p) {
  std::ostringstream os;
  os << "[" << p.x() << ", " << p.y() << ", " << p.z() << "]";
  return os.str();
}

struct RawAnchor {
  std::string label;
  std::optional<long long> vertex;
  std::optional<Vec3> position;
  std::optional<Vec2> uv;
};

RawAnchor ParseAnchor(const std::string& label, const Json& v, const std::string& where) {
  const std::string at = where + ": anchor '" + label + "'";
  RawAnchor a;
  a.label = label;
  auto vec3 = [&](const Json& x) -> Vec3 {
    if (!x.is_array() || x.size() != 3 || !x[0].is_number() || !x[1].is_number() || !x[2].is_number())
      throw Error(at + ": position must be [x, y, z] numbers");
    return Vec3(x[0].get<double>(), x[1].get<double>(), x[2].get<double>());
  };
  auto index = [&](const Json& x) -> long long {
    if (!x.is_number_integer()) throw Error(at + ": vertex must be an integer index, got " + x.dump());
    return x.get<long long>();
  };
  if (v.is_number()) {
    a.vertex = index(v);
  } else if (v.is_array()) {
    a.position = vec3(v);
  } else if (v.is_object()) {
    for (const auto& [k, x] : v.items()) {
      if (k == "vertex")
        a.vertex = index(x);
      else if (k == "position")
        a.position = vec3(x);
      else if (k == "uv") {
        if (!x.is_array() || x.size() != 2 || !x[0].is_number() || !x[1].is_number())
          throw Error(at + ": uv must be [u, v] numbers");
        a.uv = Vec2(x[0].get<double>(), x[1].get<double>());
      } else if (k != "label") {
        throw Error(at + ": unknown key '" + k + "' (expected vertex, position, uv)");
      }
    }
    if (!a.vertex && !a.position) throw Error(at + ": needs a vertex or a position");
  } else {
    throw Error(at + ": expected a vertex index, [x, y, z] or {\"vertex\": i, \"position\": [x, y, z]}");
  }
  if (a.position && !a.position->allFinite()) throw Error(at + ": position is not finite");
  return a;
}

}  // namespace

void ImportOptions::Validate() const {
  if (!(unit_scale > 0 && unit_scale <= 1e6))
    BadField(unit_scale, "unit_scale", "must be in (0, 1e6] m per file unit, got " + FormatNumber(unit_scale));
  if (!(max_anchor_distance >= 0))
    BadField(max_anchor_distance, "max_anchor_distance", "must be >= 0, got " + FormatNumber(max_anchor_distance));
}

fs::path AnchorsPath(const fs::path& mesh_path) {
  fs::path p = mesh_path;
  p.replace_extension(".anchors.json");
  return p;
}

std::string EncodeMesh(const TriMesh& mesh, std::string_view format, const Points2* uv) {
  const std::string id = ExporterId(format, "EncodeMesh");
  auto scene = MakeScene(mesh, uv);
  Assimp::Exporter exporter;
  const aiExportDataBlob* blob = exporter.ExportToBlob(scene.get(), id);
  if (!blob)
    throw Error(std::string("EncodeMesh: assimp could not export ") + std::string(format) + ": " +
                exporter.GetErrorString());
  return std::string(static_cast<const char*>(blob->data), blob->size);
}

void WriteMesh(const TriMesh& mesh, const fs::path& path, const Points2* uv) {
  const std::string ext = Lower(path.extension().string());
  const std::string id = ExporterId(ext, Where(path));
  if (id == "obj" || id == "gltf2") {
    // Multi-file formats (.obj + .mtl, .gltf + .bin): let assimp name the companions.
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    auto scene = MakeScene(mesh, uv);
    Assimp::Exporter exporter;
    if (exporter.Export(scene.get(), id, path.string()) != aiReturn_SUCCESS)
      throw Error(Where(path) + ": cannot write: " + exporter.GetErrorString());
    return;
  }
  WriteFileAtomic(path, EncodeMesh(mesh, ext.substr(1), uv));
}

namespace {

// True when the file starts with the PLY magic, whatever its extension.
bool LooksLikePly(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  char head[4] = {};
  in.read(head, 4);
  return in.gcount() == 4 && std::string_view(head, 3) == "ply" && (head[3] == '\n' || head[3] == '\r');
}

}  // namespace

TriMesh ReadMesh(const fs::path& path, double unit_scale, Points2* uv) {
  const std::string where = Where(path);
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(where + ": no such file");
  if (fs::is_directory(path, ec)) throw Error(where + ": is a directory, not a mesh file");
  const std::string ext = Lower(path.extension().string());
  MeshData m;
  if (ext == ".ply" || LooksLikePly(path))
    m = ParsePly(ReadFile(path), where);
  else if (ext == ".obj")
    m = ParseObj(ReadFile(path), where);
  else
    m = ReadWithAssimp(path);
  CheckMeshData(m, where);
  JoinIdenticalPositions(m);  // STL and texture seams repeat positions
  if (m.F.empty()) throw Error(where + ": no triangles (" + std::to_string(m.V.size()) + " vertices)");
  TriMesh out;
  out.V.resize(static_cast<int>(m.V.size()), 3);
  for (size_t i = 0; i < m.V.size(); ++i) out.V.row(static_cast<int>(i)) = m.V[i] * unit_scale;
  out.F.resize(static_cast<int>(m.F.size()), 3);
  for (size_t i = 0; i < m.F.size(); ++i) out.F.row(static_cast<int>(i)) << m.F[i][0], m.F[i][1], m.F[i][2];
  if (uv) {
    uv->resize(static_cast<int>(m.uv.size()), 2);
    for (size_t i = 0; i < m.uv.size(); ++i) uv->row(static_cast<int>(i)) = m.uv[i];
  }
  return out;
}

std::string EncodeAnchors(const Garment& g, const std::string& mesh_name) {
  Json j;
  j["format"] = "drape-anchors-1";
  j["mesh"] = mesh_name;
  j["category"] = g.category;
  j["instance"] = g.instance;
  j["units"] = "metres";
  Json anchors = Json::object();
  for (const Anchor& a : g.anchors) {
    Json e;
    e["vertex"] = a.vertex;
    e["position"] = PointJson(a.position);
    e["uv"] = PointJson(a.uv);
    anchors[a.label] = e;
  }
  j["anchors"] = anchors;
  return j.dump(2) + "\n";
}

void ExportGarment(const Garment& g, const fs::path& out) {
  ValidationOptions vo;
  vo.max_anchor_distance = std::numeric_limits<double>::infinity();  // positions are the vertices'
  ValidateGarment(g, "garment " + (g.instance.empty() ? std::string("(unnamed)") : g.instance), vo);
  WriteMesh(g.mesh, out, g.uv.rows() == g.mesh.NumVertices() ? &g.uv : nullptr);
  WriteFileAtomic(AnchorsPath(out), EncodeAnchors(g, out.filename().string()));
}

Garment ImportGarment(const fs::path& mesh_path, const fs::path& anchors_json, const ImportOptions& options,
                      ImportReport* report) {
  options.Validate();
  const std::string where = Where(mesh_path);
  Garment g;
  g.mesh = ReadMesh(mesh_path, options.unit_scale, &g.uv);
  g.category = options.category;
  g.instance = options.instance;
  // The mesh alone first, so that its errors are not hidden behind anchor errors.
  ValidateGarment(g, where, {options.max_anchor_distance, false});

  if (!anchors_json.empty()) {
    const std::string aw = Where(anchors_json);
    const Json j = ParseJsonStrict(ReadFile(anchors_json), aw);
    if (!j.is_object() && !j.is_array()) throw Error(aw + ": expected a JSON object");
    const Json* list = &j;
    if (j.is_object() && j.contains("anchors")) {
      list = &j.at("anchors");
      if (j.contains("category") && j["category"].is_string() && options.category == "custom")
        g.category = j["category"].get<std::string>();
      if (j.contains("instance") && j["instance"].is_string() && options.instance.empty())
        g.instance = j["instance"].get<std::string>();
    }
    std::vector<RawAnchor> raw;
    if (list->is_object()) {
      for (const auto& [label, v] : list->items()) raw.push_back(ParseAnchor(label, v, aw));
    } else if (list->is_array()) {
      for (size_t i = 0; i < list->size(); ++i) {
        const Json& e = (*list)[i];
        if (!e.is_object() || !e.contains("label") || !e["label"].is_string())
          throw Error(aw + ": anchors[" + std::to_string(i) + "] needs a \"label\" string");
        raw.push_back(ParseAnchor(e["label"].get<std::string>(), e, aw));
      }
    } else {
      throw Error(aw + ": \"anchors\" must be an object (label → anchor) or an array");
    }
    std::set<std::string> seen;
    for (const RawAnchor& r : raw) {
      const std::string at = aw + ": anchor '" + r.label + "'";
      if (r.label.empty()) throw Error(aw + ": an anchor has an empty label");
      if (!seen.insert(r.label).second) throw Error(aw + ": duplicate anchor label '" + r.label + "'");
      Anchor a;
      a.label = r.label;
      if (r.uv) a.uv = *r.uv;
      if (r.vertex) {
        if (*r.vertex < 0 || *r.vertex >= g.mesh.NumVertices())
          throw Error(at + ": vertex " + std::to_string(*r.vertex) + " does not exist (" + where + " has " +
                      std::to_string(g.mesh.NumVertices()) + " vertices)");
        a.vertex = static_cast<int>(*r.vertex);
      }
      if (r.position) {
        const Vec3 p = *r.position * options.unit_scale;
        const double tol = 1e-6 * std::max(1.0, p.norm());
        if (!r.vertex || (Vec3(g.mesh.V.row(a.vertex)) - p).norm() > tol) {
          const double d = DistanceToSurface(g.mesh, p);
          if (d > options.max_anchor_distance) {
            std::ostringstream os;
            os << at << ": position " << FmtVec(p) << " is " << d << " m from the surface of " << where << " (max "
               << options.max_anchor_distance << " m)";
            throw Error(os.str());
          }
          const int nearest = NearestVertex(g.mesh, p);
          if (r.vertex && report)
            report->warnings.push_back(at + ": vertex " + std::to_string(a.vertex) +
                                       " is not at the given position; snapped to vertex " + std::to_string(nearest));
          a.vertex = nearest;
        }
      }
      a.position = g.mesh.V.row(a.vertex);
      g.anchors.push_back(a);
    }
  }
  if (g.instance.empty()) g.instance = mesh_path.stem().string();
  ValidateGarment(g, where, {options.max_anchor_distance, false});
  return g;
}

}  // namespace drape
