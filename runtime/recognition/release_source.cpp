#include "runtime/recognition/release_source.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <sstream>

#include "common/error.h"
#include "garments/mesh_read.h"
#include "generator/feature/feature.h"

namespace drape::recognition {

namespace fs = std::filesystem;

EntryLabel LabelFromEntry(const Release::EntryInfo& e) {
  const Json& r = e.record;
  auto need = [&](const char* what) { return Error("entry " + e.id + ": record has no " + what); };
  EntryLabel l;
  l.id = e.id;
  l.split = e.split;
  if (!r.contains("category") || !r["category"].is_string()) throw need("\"category\"");
  l.category = r["category"].get<std::string>();
  if (r.contains("instance") && r["instance"].is_string()) l.instance = r["instance"].get<std::string>();
  if (r.contains("material") && r["material"].is_string()) l.material = r["material"].get<std::string>();
  if (!r.contains("anchor") || !r["anchor"].is_object() || !r["anchor"].contains("label")) {
    throw need("\"anchor\".\"label\"");
  }
  const Json& a = r["anchor"];
  l.anchor = a["label"].get<std::string>();
  if (a.contains("vertex") && a["vertex"].is_number_integer()) l.anchor_vertex = a["vertex"].get<int>();
  if (a.contains("uv") && a["uv"].is_array() && a["uv"].size() == 2) {
    l.anchor_uv = Vec2(a["uv"][0].get<double>(), a["uv"][1].get<double>());
  }
  return l;
}

Code LoadEntryCode(const Release& release, const Release::EntryInfo& e) {
  const std::string where = "entry " + e.id + " feature.bin";
  bool listed = false;
  for (const auto& f : e.files) listed |= f.path == "feature.bin";
  if (!listed) throw Error(where + ": the entry has no feature.bin");
  std::string bytes;
  try {
    bytes = release.ReadFile(e.id, "feature.bin");
  } catch (const Error& err) {
    throw Error(where + ": cannot read: " + err.what());
  }
  Feature f;
  try {
    f = DecodeFeature(bytes, (release.dir() / "entries" / e.id / "feature.bin").string());
  } catch (const Error& err) {
    throw Error(std::string("corrupt feature file: ") + err.what());
  }
  f.Check(where);
  return f;
}

double ReconHeight(const Release& release, const Release::EntryInfo& e) {
  bool listed = false;
  for (const auto& f : e.files) listed |= f.path == "recon.ply";
  if (!listed) return 0;
  const std::string where = (release.dir() / "entries" / e.id / "recon.ply").string();
  const MeshData m = ParsePly(release.ReadFile(e.id, "recon.ply"), where);
  if (m.V.empty()) return 0;
  double lo = m.V.front().y(), hi = lo;
  for (const Vec3& v : m.V) lo = std::min(lo, v.y()), hi = std::max(hi, v.y());
  return hi - lo;
}

std::vector<LabelledCode> LoadSplit(const Release& release, const std::string& split, LoadReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  LoadReport local;
  LoadReport& rep = report ? *report : local;
  std::vector<LabelledCode> out;
  for (const auto& e : release.entries()) {
    if (e.split != split) continue;
    if (e.failed) {
      ++rep.failed_skipped;
      rep.warnings.push_back("entry " + e.id + " failed in the build (" + e.failure + "); skipped");
      continue;
    }
    LabelledCode lc;
    lc.label = LabelFromEntry(e);
    lc.code = LoadEntryCode(release, e);
    lc.label.height = ReconHeight(release, e);
    out.push_back(std::move(lc));
    ++rep.loaded;
  }
  rep.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

Database LoadDatabase(const Release& release, LoadReport* report, Kernel kernel) {
  std::vector<LabelledCode> train = LoadSplit(release, "train", report);
  if (train.empty()) {
    throw Error(release.dir().string() + ": the release has no usable train entries, so the recognition "
                "database is empty");
  }
  for (auto& lc : train) {
    if (lc.label.anchor_vertex >= 0) lc.label.anchor_hung = std::nullopt;  // read on demand (HungVertex)
  }
  return Database(std::move(train), kernel);
}

AnchorUvMap AnchorUvs(const Release& release) {
  AnchorUvMap m;
  for (const auto& e : release.entries()) {
    try {
      const EntryLabel l = LabelFromEntry(e);
      if (l.anchor_uv && !l.instance.empty()) m.emplace(std::make_pair(l.instance, l.anchor), *l.anchor_uv);
    } catch (const Error&) {
      // entries without labels simply contribute no positions
    }
  }
  return m;
}

StageTiming EntryStageTiming(const Json& build_info, const std::string& id) {
  StageTiming t;
  if (!build_info.is_object() || !build_info.contains("entry_timing")) return t;
  const Json& et = build_info["entry_timing"];
  if (!et.contains(id)) return t;
  // Depth-first over the entry's timing object: the first numeric field whose key names
  // the stage ("fusion_seconds", "fuse", {"fusion": {"seconds": …}}, …).
  std::function<void(const Json&, const std::string&)> walk = [&](const Json& j, const std::string& path) {
    for (const auto& [k, v] : j.items()) {
      const std::string key = path.empty() ? k : path + "." + k;
      if (v.is_object()) {
        walk(v, key);
      } else if (v.is_number()) {
        std::string low = key;
        for (char& c : low) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (t.fusion_seconds < 0 && low.find("fus") != std::string::npos) t.fusion_seconds = v.get<double>();
        if (t.feature_seconds < 0 && low.find("feature") != std::string::npos) t.feature_seconds = v.get<double>();
      }
    }
  };
  walk(et[id], "");
  if (t.fusion_seconds >= 0 || t.feature_seconds >= 0) t.source = "build.json entry_timing (the build's own run)";
  return t;
}

namespace {

// Minimal PLY vertex reader (ascii or binary little-endian; x, y, z float or double).
std::optional<Vec3> PlyVertex(const std::string& bytes, int vertex) {
  size_t pos = bytes.find("end_header");
  if (bytes.rfind("ply", 0) != 0 || pos == std::string::npos) return std::nullopt;
  const size_t body = bytes.find('\n', pos) + 1;
  std::istringstream hs(bytes.substr(0, pos));
  std::string line, format;
  long long n_vertex = -1;
  bool in_vertex = false, before_vertex = true;
  size_t skip_bytes = 0;  // binary: elements before "vertex" are not expected
  struct Prop { std::string name, type; };
  std::vector<Prop> props;
  while (std::getline(hs, line)) {
    std::istringstream ls(line);
    std::string w;
    ls >> w;
    if (w == "format") {
      ls >> format;
    } else if (w == "element") {
      std::string name;
      long long n;
      ls >> name >> n;
      in_vertex = name == "vertex";
      if (in_vertex) n_vertex = n, before_vertex = false;
      else if (before_vertex) return std::nullopt;
    } else if (w == "property" && in_vertex) {
      std::string type, name;
      ls >> type;
      if (type == "list") return std::nullopt;
      ls >> name;
      props.push_back({name, type});
    }
  }
  (void)skip_bytes;
  if (vertex < 0 || vertex >= n_vertex) return std::nullopt;
  auto size_of = [](const std::string& t) -> size_t {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
  };
  Vec3 p = Vec3::Zero();
  if (format == "binary_little_endian") {
    size_t stride = 0;
    for (const auto& pr : props) {
      if (!size_of(pr.type)) return std::nullopt;
      stride += size_of(pr.type);
    }
    size_t off = body + stride * size_t(vertex);
    if (off + stride > bytes.size()) return std::nullopt;
    for (const auto& pr : props) {
      const int axis = pr.name == "x" ? 0 : pr.name == "y" ? 1 : pr.name == "z" ? 2 : -1;
      if (axis >= 0) {
        if (pr.type == "float" || pr.type == "float32") {
          float f;
          std::memcpy(&f, bytes.data() + off, 4);
          p[axis] = f;
        } else if (pr.type == "double" || pr.type == "float64") {
          std::memcpy(&p[axis], bytes.data() + off, 8);
        }
      }
      off += size_of(pr.type);
    }
    return p;
  }
  if (format == "ascii") {
    std::istringstream bs(bytes.substr(body));
    for (int i = 0; i <= vertex; ++i) std::getline(bs, line);
    std::istringstream ls(line);
    for (const auto& pr : props) {
      double v;
      ls >> v;
      if (pr.name == "x") p[0] = v;
      if (pr.name == "y") p[1] = v;
      if (pr.name == "z") p[2] = v;
    }
    return p;
  }
  return std::nullopt;
}

}  // namespace

std::optional<Vec3> HungVertex(const Release& release, const std::string& id, int vertex) {
  if (vertex < 0) return std::nullopt;
  const Release::EntryInfo* e = release.Find(id);
  if (!e) return std::nullopt;
  bool listed = false;
  for (const auto& f : e->files) listed |= f.path == "hang.ply";
  if (!listed) return std::nullopt;
  try {
    return PlyVertex(release.ReadFile(id, "hang.ply"), vertex);
  } catch (const Error&) {
    return std::nullopt;
  }
}

fs::path DefaultWeightsDir(const Release& release) { return release.dir() / "calibration"; }

std::vector<EvalQuery> LoadEvalQueries(const Release& release, const std::string& split, LoadReport* report) {
  std::vector<LabelledCode> qs = LoadSplit(release, split, report);
  const Json build = release.build_info();
  std::vector<EvalQuery> out;
  for (auto& q : qs) {
    EvalQuery eq;
    const StageTiming t = EntryStageTiming(build, q.label.id);
    eq.fusion_seconds = t.fusion_seconds;
    eq.feature_seconds = t.feature_seconds;
    eq.timing_source = t.source.empty() ? "no build timing recorded" : t.source;
    eq.query = std::move(q);
    out.push_back(std::move(eq));
  }
  return out;
}

}  // namespace drape::recognition
