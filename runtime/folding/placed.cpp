#include "runtime/folding/placed.h"

#include "common/error.h"
#include "common/files.h"
#include "common/json.h"
#include "garments/io.h"

namespace drape::folding {
namespace fs = std::filesystem;

namespace {
constexpr const char* kFormat = "drape-placed-1";

Json ParseJsonFile(const fs::path& file) {
  if (!fs::exists(file)) throw Error(file.string() + ": no such file");
  try {
    return Json::parse(ReadFile(file));
  } catch (const Json::exception& e) {
    throw Error(file.string() + ": " + e.what());
  }
}

// The placed.json a path leads to: itself, the folder's, or the one a trace names.
fs::path PlacedJson(const fs::path& path) {
  if (fs::is_directory(path)) {
    if (fs::exists(path / "placed.json")) return path / "placed.json";
    return PlacedJson(path / "trace.json");
  }
  if (path.filename() != "trace.json") return path;
  const Json trace = ParseJsonFile(path);
  const Json name = trace.value("placed_garment", Json());
  if (!name.is_string()) {
    std::string why = trace.value("placed", false) ? "" : " (placed: false";
    if (!why.empty()) {
      const Json f = trace.value("place_failure", Json());
      if (f.is_string() && !f.get<std::string>().empty()) why += ": " + f.get<std::string>();
      const Json g = trace.value("failure", Json());
      if (f.is_string() && f.get<std::string>().empty() && g.is_string() && !g.get<std::string>().empty())
        why += "; the trial: " + g.get<std::string>();
      why += ")";
    }
    throw Error(path.string() + ": the trial did not place its garment flat on the table" + why);
  }
  return path.parent_path() / name.get<std::string>();
}
}  // namespace

void WritePlacedGarment(const fs::path& dir, const PlacedGarment& p) {
  const int n = p.garment.mesh.NumVertices();
  if (p.lying.rows() != n) throw Error("WritePlacedGarment: the lying garment's vertices do not match its pattern's");
  fs::create_directories(dir);
  ExportGarment(p.garment, dir / "garment.ply");
  WriteMesh(TriMesh{p.lying, p.garment.mesh.F}, dir / "lying.ply");
  const Json doc = {{"format", kFormat},        {"category", p.garment.category}, {"instance", p.garment.instance},
                    {"garment", "garment.ply"}, {"lying", "lying.ply"},           {"layer", p.garment.layer},
                    {"material", p.material},   {"stiffness", p.stiffness},       {"friction", p.friction}};
  WriteFileAtomic(dir / "placed.json", doc.dump(2) + "\n");
}

bool IsPlacedGarmentPath(const fs::path& path) {
  if (fs::is_directory(path)) return fs::exists(path / "placed.json") || fs::exists(path / "trace.json");
  return fs::is_regular_file(path) && (path.filename() == "placed.json" || path.filename() == "trace.json");
}

PlacedGarment ReadPlacedGarment(const fs::path& path) {
  const fs::path file = PlacedJson(path);
  const Json doc = ParseJsonFile(file);
  const std::string where = file.string() + ": ";
  if (doc.value("format", "") != kFormat) throw Error(where + "format is not '" + std::string(kFormat) + "'");
  PlacedGarment p;
  try {
    const fs::path dir = file.parent_path();
    const fs::path mesh = dir / doc.at("garment").get<std::string>();
    ImportOptions io;
    io.category = doc.at("category").get<std::string>();
    io.instance = doc.at("instance").get<std::string>();
    p.garment = ImportGarment(mesh, AnchorsPath(mesh), io);
    const TriMesh lying = ReadMesh(dir / doc.at("lying").get<std::string>());
    if (lying.NumVertices() != p.garment.mesh.NumVertices() || lying.NumFaces() != p.garment.mesh.NumFaces() ||
        !(lying.F == p.garment.mesh.F))
      throw Error(where + "'lying' and 'garment' are not the same mesh (" + std::to_string(lying.NumVertices()) +
                  " and " + std::to_string(p.garment.mesh.NumVertices()) + " vertices, or other faces)");
    p.lying = lying.V;
    p.garment.layer = doc.at("layer").get<std::vector<int>>();
    if (!p.garment.layer.empty() && static_cast<int>(p.garment.layer.size()) != p.garment.mesh.NumVertices())
      throw Error(where + "'layer' has " + std::to_string(p.garment.layer.size()) + " entries, the mesh " +
                  std::to_string(p.garment.mesh.NumVertices()) + " vertices");
    p.material = doc.at("material").get<std::string>();
    p.stiffness = doc.at("stiffness").get<double>();
    p.friction = doc.at("friction").get<double>();
  } catch (const Json::exception& e) {
    throw Error(where + e.what());
  }
  if (!(p.stiffness > 0 && p.stiffness <= 1)) throw Error(where + "stiffness must be in (0, 1]");
  if (!(p.friction >= 0 && p.friction < 5)) throw Error(where + "friction must be in [0, 5)");
  return p;
}

}  // namespace drape::folding
