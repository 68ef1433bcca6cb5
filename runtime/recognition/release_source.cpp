#include "runtime/recognition/release_source.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <sstream>

#include "common/error.h"
#include "common/timing.h"
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
  if (r.contains("hang_index")) {  // hangs 1..K−1 of `hangs_per_anchor: K`; absent for hang 0
    if (!r["hang_index"].is_number_integer() || r["hang_index"].get<int>() < 1)
      throw Error("entry " + e.id + ": record \"hang_index\" is not an integer ≥ 1");
    l.hang = r["hang_index"].get<int>();
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

namespace {
std::optional<double> PlyHeight(const std::string& bytes);
}  // namespace

double ReconHeight(const Release& release, const Release::EntryInfo& e) {
  bool listed = false;
  for (const auto& f : e.files) listed |= f.path == "recon.ply";
  if (!listed) return 0;
  const std::string bytes = release.ReadFile(e.id, "recon.ply");
  if (const auto h = PlyHeight(bytes)) return *h;
  // Another PLY layout than drape writes: the full reader (throws naming the file).
  const MeshData m = ParsePly(bytes, (release.dir() / "entries" / e.id / "recon.ply").string());
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec3& v : m.V) lo = std::min(lo, v.y()), hi = std::max(hi, v.y());
  return hi >= lo ? hi - lo : 0.0;
}

std::vector<LabelledCode> LoadSplit(const Release& release, const std::string& split, LoadReport* report) {
  const auto t0 = Clock::now();
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
  rep.seconds += Since(t0);
  return out;
}

Database LoadDatabase(const Release& release, LoadReport* report, Kernel kernel) {
  std::vector<LabelledCode> train = LoadSplit(release, "train", report);
  if (train.empty()) {
    throw Error(release.dir().string() +
                ": the release has no usable train entries, so the recognition "
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

// The vertex block of a PLY as the minimal readers below take it: ascii or binary
// little-endian, "vertex" the first element, scalar properties (x, y, z float or double).
// They read a vertex or the heights without parsing the faces, which are most of a
// reconstruction's bytes.
struct PlyVertexBlock {
  struct Prop {
    int axis = -1;  // 0, 1, 2 for x, y, z
    std::string type;
    size_t size = 0;
  };
  std::string format;
  size_t body = 0;  // first byte after the header
  long long count = -1;
  std::vector<Prop> props;
  size_t stride = 0;  // binary: bytes per vertex
};

size_t PlyTypeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

std::optional<PlyVertexBlock> VertexBlock(const std::string& bytes) {
  const size_t pos = bytes.find("end_header");
  if (bytes.rfind("ply", 0) != 0 || pos == std::string::npos) return std::nullopt;
  PlyVertexBlock b;
  b.body = bytes.find('\n', pos) + 1;
  std::istringstream hs(bytes.substr(0, pos));
  std::string line;
  bool in_vertex = false;
  while (std::getline(hs, line)) {
    std::istringstream ls(line);
    std::string w;
    ls >> w;
    if (w == "format") {
      ls >> b.format;
    } else if (w == "element") {
      std::string name;
      long long n;
      ls >> name >> n;
      in_vertex = name == "vertex";
      if (in_vertex) {
        b.count = n;
      } else if (b.count < 0) {
        return std::nullopt;  // an element before the vertices
      }
    } else if (w == "property" && in_vertex) {
      PlyVertexBlock::Prop pr;
      std::string name;
      ls >> pr.type;
      if (pr.type == "list") return std::nullopt;
      ls >> name;
      pr.axis = name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : -1;
      pr.size = PlyTypeSize(pr.type);
      b.stride += pr.size;
      b.props.push_back(pr);
    }
  }
  if (b.count < 0 || (b.format != "ascii" && b.format != "binary_little_endian")) return std::nullopt;
  if (b.format != "ascii") {
    for (const auto& pr : b.props) {
      if (pr.size == 0) return std::nullopt;
    }
  }
  return b;
}

// Vertex i of a binary block (the caller checked that its bytes are there).
Vec3 BinaryVertex(const std::string& bytes, const PlyVertexBlock& b, long long i) {
  Vec3 p = Vec3::Zero();
  size_t off = b.body + b.stride * size_t(i);
  for (const auto& pr : b.props) {
    if (pr.axis >= 0 && pr.size == 4 && pr.type.rfind("float", 0) == 0) {
      float f;
      std::memcpy(&f, bytes.data() + off, 4);
      p[pr.axis] = f;
    } else if (pr.axis >= 0 && pr.size == 8) {
      std::memcpy(&p[pr.axis], bytes.data() + off, 8);
    }
    off += pr.size;
  }
  return p;
}

Vec3 AsciiVertex(const std::string& line, const PlyVertexBlock& b) {
  std::istringstream ls(line);
  Vec3 p = Vec3::Zero();
  for (const auto& pr : b.props) {
    double v = 0;
    ls >> v;
    if (pr.axis >= 0) p[pr.axis] = v;
  }
  return p;
}

// Calls f(vertex) for the first `n` vertices (all when n < 0); false if unreadable.
template <typename F>
bool ForEachVertex(const std::string& bytes, long long n, F&& f) {
  const auto b = VertexBlock(bytes);
  if (!b) return false;
  if (n < 0 || n > b->count) n = b->count;
  if (b->format == "binary_little_endian") {
    if (b->body + b->stride * size_t(n) > bytes.size()) return false;
    for (long long i = 0; i < n; ++i) f(BinaryVertex(bytes, *b, i));
    return true;
  }
  std::istringstream bs(bytes.substr(b->body));
  std::string line;
  for (long long i = 0; i < n; ++i) {
    if (!std::getline(bs, line)) return false;
    f(AsciiVertex(line, *b));
  }
  return true;
}

std::optional<Vec3> PlyVertex(const std::string& bytes, int vertex) {
  const auto b = VertexBlock(bytes);
  if (!b || vertex < 0 || vertex >= b->count) return std::nullopt;
  if (b->format == "binary_little_endian") {
    if (b->body + b->stride * size_t(vertex + 1) > bytes.size()) return std::nullopt;
    return BinaryVertex(bytes, *b, vertex);
  }
  Vec3 last;
  if (!ForEachVertex(bytes, vertex + 1, [&](const Vec3& p) { last = p; })) return std::nullopt;
  return last;
}

// The y extent of a PLY's vertices; nullopt if the minimal reader cannot read it.
std::optional<double> PlyHeight(const std::string& bytes) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  if (!ForEachVertex(bytes, -1, [&](const Vec3& p) { lo = std::min(lo, p.y()), hi = std::max(hi, p.y()); })) {
    return std::nullopt;
  }
  return hi >= lo ? hi - lo : 0.0;
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

fs::path ResolveWeightsPath(const Release& release, const std::string& spec) {
  if (spec == "none") return {};
  if (!spec.empty()) return spec;
  const fs::path own = DefaultWeightsDir(release) / "weights.json";
  return fs::exists(own) ? own : fs::path();
}

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
