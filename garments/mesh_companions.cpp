#include "garments/mesh_companions.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/error.h"
#include "common/files.h"

namespace drape {
namespace {

namespace fs = std::filesystem;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// glTF URIs are percent-encoded (glTF 2.0 §3.2.4): "my%20mesh.bin" names "my mesh.bin".
std::string PercentDecode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

// "scheme:" (data:, http:, file:, …) marks a URI that is not a relative file path.
bool HasScheme(const std::string& uri) {
  const size_t colon = uri.find(':');
  if (colon == std::string::npos || colon < 2) return false;  // "C:" would be a drive, not a scheme
  return std::all_of(uri.begin(), uri.begin() + static_cast<long>(colon), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '+' || c == '-' || c == '.';
  });
}

class Collector {
 public:
  explicit Collector(fs::path mesh) : mesh_(std::move(mesh)), dir_(mesh_.parent_path()) {}

  // `ref` as written in `from` (a path relative to the mesh's folder, "" = the mesh).
  // Returns the companion's path relative to the mesh's folder, or "" when left out.
  std::string Add(const std::string& from, const std::string& ref) {
    if (ref.empty() || HasScheme(ref)) return "";
    const fs::path r(ref);
    const fs::path rel = (fs::path(from).parent_path() / r).lexically_normal();
    std::string s = rel.generic_string();
    if (r.is_absolute() || s.empty() || s == "." || s.rfind("..", 0) == 0)
      throw Error((dir_ / (from.empty() ? mesh_.filename() : fs::path(from))).string() + ": refers to '" + ref +
                  "', outside the mesh's folder: a release can only carry files at or below it (move it there)");
    std::error_code ec;
    if (!fs::is_regular_file(dir_ / rel, ec)) return "";
    if (std::find(out_.begin(), out_.end(), s) == out_.end()) out_.push_back(s);
    return s;
  }

  const std::vector<std::string>& out() const { return out_; }

 private:
  fs::path mesh_, dir_;
  std::vector<std::string> out_;
};

// The JSON chunk of a .glb (header: magic, version, length; then chunk length, "JSON").
std::string GlbJson(const std::string& bytes) {
  if (bytes.size() < 20 || bytes.compare(0, 4, "glTF") != 0 || bytes.compare(16, 4, "JSON") != 0) return "";
  uint32_t len = 0;
  std::memcpy(&len, bytes.data() + 12, 4);  // little-endian, as this machine
  if (len > bytes.size() - 20) return "";
  return bytes.substr(20, len);
}

void GltfCompanions(const fs::path& mesh, bool binary, Collector& c) {
  std::string text = ReadFile(mesh);
  if (binary) text = GlbJson(text);
  if (text.empty()) return;  // not a GLB assimp could read either: the import says why
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw Error(mesh.string() + ": not glTF JSON");
  for (const char* key : {"buffers", "images"}) {
    const auto it = j.find(key);
    if (it == j.end() || !it->is_array()) continue;
    for (const auto& item : *it) {
      if (!item.is_object()) continue;
      const auto uri = item.find("uri");
      if (uri != item.end() && uri->is_string()) c.Add("", PercentDecode(uri->get<std::string>()));
    }
  }
}

// Words of a line after its keyword; the last one for texture statements, whose
// options ("-s 1 1 1", "-bm 0.5") come before the file name.
std::vector<std::string> Words(std::istringstream& in) {
  std::vector<std::string> w;
  for (std::string s; in >> s;) w.push_back(s);
  return w;
}

void MtlCompanions(const fs::path& dir, const std::string& mtl, Collector& c) {
  static const char* kMaps[] = {"map_ka", "map_kd", "map_ks", "map_ke", "map_ns", "map_d",  "map_bump", "bump",
                                "disp",   "decal",  "refl",   "norm",   "map_pr", "map_pm", "map_ps"};
  std::istringstream lines(ReadFile(dir / mtl));
  for (std::string line; std::getline(lines, line);) {
    std::istringstream in(line);
    std::string key;
    if (!(in >> key)) continue;
    key = Lower(key);
    if (std::find(std::begin(kMaps), std::end(kMaps), key) == std::end(kMaps)) continue;
    const auto w = Words(in);
    if (!w.empty()) c.Add(mtl, w.back());
  }
}

void ObjCompanions(const fs::path& mesh, Collector& c) {
  std::istringstream lines(ReadFile(mesh));
  std::vector<std::string> mtls;
  for (std::string line; std::getline(lines, line);) {
    std::istringstream in(line);
    std::string key;
    if (!(in >> key) || key != "mtllib") continue;
    for (const auto& name : Words(in)) {
      const std::string rel = c.Add("", name);
      if (!rel.empty()) mtls.push_back(rel);
    }
  }
  for (const auto& m : mtls) MtlCompanions(mesh.parent_path(), m, c);
}

}  // namespace

std::vector<std::string> MeshCompanions(const fs::path& mesh) {
  const std::string ext = Lower(mesh.extension().string());
  Collector c(mesh);
  if (ext == ".gltf" || ext == ".glb")
    GltfCompanions(mesh, ext == ".glb", c);
  else if (ext == ".obj")
    ObjCompanions(mesh, c);
  return c.out();
}

}  // namespace drape
