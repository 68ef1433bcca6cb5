#include "garments/mesh_read.h"

#include <assimp/BaseImporter.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <numeric>
#include <optional>
#include <set>

#include "common/error.h"
#include "common/files.h"
#include "common/format.h"

namespace drape {
namespace {

// ---- PLY -------------------------------------------------------------------------

enum class PlyFormat { kAscii, kLittle, kBig };

struct PlyProperty {
  std::string name;
  int type = 0;  // byte size of the value (negative codes below for float kinds)
  bool is_float = false;
  bool is_signed = false;
  bool is_list = false;
  int count_size = 0;  // list length type size
  bool count_signed = false;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> props;
};

std::vector<std::string_view> Words(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// Sets size/float/signed from a PLY type name; false when unknown.
bool PlyType(std::string_view t, int* size, bool* is_float, bool* is_signed) {
  struct T {
    const char* a;
    const char* b;
    int size;
    bool f, s;
  };
  static const T kTypes[] = {{"char", "int8", 1, false, true},    {"uchar", "uint8", 1, false, false},
                             {"short", "int16", 2, false, true},  {"ushort", "uint16", 2, false, false},
                             {"int", "int32", 4, false, true},    {"uint", "uint32", 4, false, false},
                             {"float", "float32", 4, true, true}, {"double", "float64", 8, true, true}};
  for (const T& x : kTypes)
    if (t == x.a || t == x.b) {
      *size = x.size, *is_float = x.f, *is_signed = x.s;
      return true;
    }
  return false;
}

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t body = 0;  // offset of the first body byte
};

PlyHeader ParsePlyHeader(std::string_view bytes, const std::string& where) {
  if (bytes.substr(0, 4) != "ply\n" && bytes.substr(0, 5) != "ply\r\n")
    throw Error(where + ": cannot read mesh: not a PLY file (does not start with \"ply\")");
  PlyHeader h;
  bool have_format = false;
  size_t pos = 0;
  for (int line_no = 1;; ++line_no) {
    const size_t nl = bytes.find('\n', pos);
    if (nl == std::string_view::npos) throw Error(where + ": PLY header has no end_header line");
    const std::string_view line = bytes.substr(pos, nl - pos);
    pos = nl + 1;
    const std::string at = where + ":" + std::to_string(line_no);
    const auto w = Words(line);
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info" || (line_no == 1 && w[0] == "ply")) continue;
    if (w[0] == "end_header") break;
    if (w[0] == "format") {
      if (w.size() < 2) throw Error(at + ": format line needs a format name");
      if (w[1] == "ascii")
        h.format = PlyFormat::kAscii;
      else if (w[1] == "binary_little_endian")
        h.format = PlyFormat::kLittle;
      else if (w[1] == "binary_big_endian")
        h.format = PlyFormat::kBig;
      else
        throw Error(at + ": unknown PLY format '" + std::string(w[1]) + "'");
      have_format = true;
    } else if (w[0] == "element") {
      if (w.size() != 3) throw Error(at + ": expected 'element NAME COUNT'");
      PlyElement e;
      e.name = std::string(w[1]);
      const auto r = std::from_chars(w[2].data(), w[2].data() + w[2].size(), e.count);
      if (r.ec != std::errc() || r.ptr != w[2].data() + w[2].size() || e.count > (1u << 30))
        throw Error(at + ": element count '" + std::string(w[2]) + "' is not a count");
      h.elements.push_back(std::move(e));
    } else if (w[0] == "property") {
      if (h.elements.empty()) throw Error(at + ": property before any element");
      PlyProperty p;
      bool ok;
      if (w.size() == 5 && w[1] == "list") {
        bool count_float;
        ok = PlyType(w[2], &p.count_size, &count_float, &p.count_signed) && !count_float &&
             PlyType(w[3], &p.type, &p.is_float, &p.is_signed);
        p.is_list = true;
        p.name = std::string(w[4]);
      } else {
        ok = w.size() == 3 && PlyType(w[1], &p.type, &p.is_float, &p.is_signed);
        p.name = ok ? std::string(w[2]) : "";
      }
      if (!ok) throw Error(at + ": cannot read property line '" + std::string(line) + "'");
      h.elements.back().props.push_back(std::move(p));
    } else {
      throw Error(at + ": unexpected PLY header line '" + std::string(line) + "'");
    }
  }
  if (!have_format) throw Error(where + ": PLY header has no format line");
  h.body = pos;
  return h;
}

// Reads body values one at a time; throws at the end of the data.
class PlyReader {
 public:
  PlyReader(std::string_view bytes, size_t pos, PlyFormat f, const std::string& where)
      : b_(bytes), pos_(pos), f_(f), where_(where) {}

  double Read(int size, bool is_float, bool is_signed) {
    if (f_ == PlyFormat::kAscii) return ReadAscii(is_float && size == 4);
    if (b_.size() - pos_ < static_cast<size_t>(size)) Truncated();
    const auto* p = reinterpret_cast<const unsigned char*>(b_.data() + pos_);
    pos_ += size;
    return At(p, size, is_float, is_signed, swap());
  }
  size_t Remaining() const { return b_.size() - pos_; }
  bool ascii() const { return f_ == PlyFormat::kAscii; }
  // Binary bodies: the next n bytes (checked), for the fixed-layout fast paths below.
  const unsigned char* Take(size_t n) {
    if (Remaining() < n) Truncated();
    const auto* p = reinterpret_cast<const unsigned char*>(b_.data() + pos_);
    pos_ += n;
    return p;
  }
  unsigned char Peek() const { return static_cast<unsigned char>(b_[pos_]); }  // needs Remaining() > 0
  bool swap() const { return (f_ == PlyFormat::kBig) == (std::endian::native == std::endian::little); }
  // One binary value at p (in file byte order).
  static double At(const unsigned char* p, int size, bool is_float, bool is_signed, bool swap) {
    if (!swap) return Decode(p, size, is_float, is_signed);
    unsigned char buf[8];
    std::reverse_copy(p, p + size, buf);
    return Decode(buf, size, is_float, is_signed);
  }
  [[noreturn]] void Truncated() const { throw Error(where_ + ": PLY data ends early (truncated file?)"); }

 private:
  static double Decode(const unsigned char* p, int size, bool is_float, bool is_signed) {
    if (is_float) {
      if (size == 4) return std::bit_cast<float>(Load<uint32_t>(p));
      return std::bit_cast<double>(Load<uint64_t>(p));
    }
    switch (size) {
      case 1:
        return is_signed ? static_cast<double>(static_cast<int8_t>(p[0])) : p[0];
      case 2:
        return is_signed ? static_cast<double>(static_cast<int16_t>(Load<uint16_t>(p))) : Load<uint16_t>(p);
      default:
        return is_signed ? static_cast<double>(static_cast<int32_t>(Load<uint32_t>(p))) : Load<uint32_t>(p);
    }
  }
  template <class U>
  static U Load(const unsigned char* p) {
    U u;
    std::memcpy(&u, p, sizeof u);
    return u;
  }
  double ReadAscii(bool as_float) {
    while (pos_ < b_.size() && std::isspace(static_cast<unsigned char>(b_[pos_]))) ++pos_;
    if (pos_ == b_.size()) Truncated();
    size_t end = pos_;
    while (end < b_.size() && !std::isspace(static_cast<unsigned char>(b_[end]))) ++end;
    const char* first = b_.data() + pos_ + (b_[pos_] == '+' ? 1 : 0);
    double v = 0;
    float f = 0;  // a float property is the float nearest to the text, like a binary one
    auto r = as_float ? std::from_chars(first, b_.data() + end, f) : std::from_chars(first, b_.data() + end, v);
    if (as_float && r.ec == std::errc::result_out_of_range) {  // 1e-50 → 0, 1e50 → inf
      r = std::from_chars(first, b_.data() + end, v);
      f = static_cast<float>(v);
    }
    if (as_float) v = f;
    if (r.ec != std::errc() || r.ptr != b_.data() + end)
      throw Error(where_ + ": PLY value '" + std::string(b_.substr(pos_, std::min<size_t>(end - pos_, 40))) +
                  "' is not a number");
    pos_ = end;
    return v;
  }

  std::string_view b_;
  size_t pos_;
  PlyFormat f_;
  const std::string& where_;
};

// Smallest byte size of one element in a binary body (lists count their length only).
size_t MinElementBytes(const PlyElement& e, bool ascii) {
  size_t n = 0;
  for (const PlyProperty& p : e.props) n += ascii ? 1 : (p.is_list ? p.count_size : p.type);
  return std::max<size_t>(n, 1);
}

int PropIndex(const PlyElement& e, std::initializer_list<const char*> names) {
  for (const char* name : names)
    for (size_t i = 0; i < e.props.size(); ++i)
      if (!e.props[i].is_list && e.props[i].name == name) return static_cast<int>(i);
  return -1;
}

// A list length, as a non-negative count that the remaining data could hold. `at()`
// names the element (built only for the message: this runs once per face).
template <class At>
size_t ListLength(PlyReader& r, const PlyProperty& p, const At& at) {
  const double n = r.Read(p.count_size, false, p.count_signed);
  if (!(n >= 0) || n != std::floor(n) || n > static_cast<double>(r.Remaining()))
    throw Error(at() + ": list length " + FormatNumber(n) + " is not possible here");  // may be nan or 1e300
  return static_cast<size_t>(n);
}

void ReadPlyVertices(PlyReader& r, const PlyElement& e, MeshData& m, const std::string& where) {
  const int x = PropIndex(e, {"x"}), y = PropIndex(e, {"y"}), z = PropIndex(e, {"z"});
  if (x < 0 || y < 0 || z < 0) throw Error(where + ": PLY vertex element needs x, y and z properties");
  const int u = PropIndex(e, {"s", "u", "texture_u", "texture_s"});
  const int v = PropIndex(e, {"t", "v", "texture_v", "texture_t"});
  const bool has_uv = u >= 0 && v >= 0;
  std::vector<double> val(e.props.size());
  m.V.reserve(e.count);
  if (has_uv) m.uv.reserve(e.count);
  const bool any_list = std::any_of(e.props.begin(), e.props.end(), [](const PlyProperty& p) { return p.is_list; });
  if (!r.ascii() && !any_list) {
    // Fixed-size binary records (every file drape writes): one bounds check for the
    // element, then each property read at its offset in the record.
    size_t stride = 0;
    std::vector<size_t> offset(e.props.size());
    for (size_t k = 0; k < e.props.size(); ++k) offset[k] = stride, stride += e.props[k].type;
    const unsigned char* base = r.Take(e.count * stride);
    const bool swap = r.swap();
    auto get = [&](const unsigned char* rec, int k) {
      const PlyProperty& p = e.props[k];
      return PlyReader::At(rec + offset[k], p.type, p.is_float, p.is_signed, swap);
    };
    for (uint64_t i = 0; i < e.count; ++i) {
      const unsigned char* rec = base + i * stride;
      m.V.emplace_back(get(rec, x), get(rec, y), get(rec, z));
      if (has_uv) m.uv.emplace_back(get(rec, u), get(rec, v));
    }
    return;
  }
  for (uint64_t i = 0; i < e.count; ++i) {
    for (size_t k = 0; k < e.props.size(); ++k) {
      const PlyProperty& p = e.props[k];
      if (p.is_list) {
        const size_t n = ListLength(r, p, [&] { return where + ": vertex " + std::to_string(i); });
        for (size_t j = 0; j < n; ++j) r.Read(p.type, p.is_float, p.is_signed);
      } else {
        val[k] = r.Read(p.type, p.is_float, p.is_signed);
      }
    }
    m.V.emplace_back(val[x], val[y], val[z]);
    if (has_uv) m.uv.emplace_back(val[u], val[v]);
  }
}

void ReadPlyFaces(PlyReader& r, const PlyElement& e, MeshData& m, const std::string& where) {
  int list = -1;
  for (size_t k = 0; k < e.props.size(); ++k)
    if (e.props[k].is_list && (e.props[k].name == "vertex_indices" || e.props[k].name == "vertex_index"))
      list = static_cast<int>(k);
  if (list < 0) throw Error(where + ": PLY face element needs a vertex_indices list property");
  m.F.reserve(e.count);
  std::vector<int> poly;
  const PlyProperty& lp = e.props[list];
  const bool tri_fast = e.props.size() == 1 && !r.ascii() && lp.count_size == 1 && !lp.is_float && lp.type == 4;
  const bool swap = r.swap();
  for (uint64_t i = 0; i < e.count; ++i) {
    const auto at = [&] { return where + ": face " + std::to_string(i); };
    if (tri_fast && r.Remaining() >= 13 && r.Peek() == 3) {
      // The binary triangle drape writes (uchar 3, three 4-byte indices), read in place.
      const unsigned char* q = r.Take(13) + 1;
      std::array<int, 3> f;
      for (int k = 0; k < 3; ++k) {
        const double idx = PlyReader::At(q + 4 * static_cast<ptrdiff_t>(k), 4, false, e.props[list].is_signed, swap);
        if (!(idx >= 0 && idx < 2147483647.0))
          throw Error(at() + ": vertex index " + FormatNumber(idx) + " is not a valid index");
        f[k] = static_cast<int>(idx);
      }
      m.F.push_back(f);
      continue;
    }
    for (size_t k = 0; k < e.props.size(); ++k) {
      const PlyProperty& p = e.props[k];
      if (!p.is_list) {
        r.Read(p.type, p.is_float, p.is_signed);
        continue;
      }
      const size_t n = ListLength(r, p, at);
      if (static_cast<int>(k) != list) {
        for (size_t j = 0; j < n; ++j) r.Read(p.type, p.is_float, p.is_signed);
        continue;
      }
      poly.clear();
      for (size_t j = 0; j < n; ++j) {
        const double idx = r.Read(p.type, p.is_float, p.is_signed);
        if (!(idx >= 0 && idx < 2147483647.0) || idx != std::floor(idx))
          throw Error(at() + ": vertex index " + FormatNumber(idx) + " is not a valid index");
        poly.push_back(static_cast<int>(idx));
      }
      if (n < 3) throw Error(at() + ": has " + std::to_string(n) + " vertex indices (a face needs at least 3)");
      for (size_t j = 1; j + 1 < n; ++j) m.F.push_back({poly[0], poly[j], poly[j + 1]});
    }
  }
}

// ---- OBJ -------------------------------------------------------------------------

// OBJ numbers are read as float32, as assimp (and so drape's writer) store them: a
// written file reads back bit for bit.
std::optional<double> Number(std::string_view s) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  float v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec == std::errc::result_out_of_range) {  // 1e-50 → 0, 1e50 → inf (then rejected)
    double d = 0;
    std::from_chars(s.data(), s.data() + s.size(), d);
    return static_cast<float>(d);
  }
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// An OBJ index (1-based, or negative = relative to the `count` seen so far) → 0-based.
int ObjIndex(std::string_view s, size_t count, const std::string& at) {
  long long k = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), k);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || k == 0)
    throw Error(at + ": bad index '" + std::string(s.substr(0, 40)) + "'");
  const long long i = k > 0 ? k - 1 : static_cast<long long>(count) + k;
  if (i < 0 || i >= (1ll << 31)) throw Error(at + ": index " + std::to_string(k) + " is out of range");
  return static_cast<int>(i);
}

}  // namespace

MeshData ParsePly(std::string_view bytes, const std::string& where) {
  const PlyHeader h = ParsePlyHeader(bytes, where);
  PlyReader r(bytes, h.body, h.format, where);
  MeshData m;
  bool have_vertices = false;
  for (const PlyElement& e : h.elements) {
    if (e.count > r.Remaining() / MinElementBytes(e, r.ascii())) r.Truncated();
    if (e.name == "vertex" && !have_vertices) {
      ReadPlyVertices(r, e, m, where);
      have_vertices = true;
    } else if (e.name == "face" && m.F.empty()) {
      ReadPlyFaces(r, e, m, where);
    } else {
      for (uint64_t i = 0; i < e.count; ++i)
        for (const PlyProperty& p : e.props) {
          const size_t n =
              p.is_list ? ListLength(r, p, [&] { return where + ": " + e.name + " " + std::to_string(i); }) : 1;
          for (size_t j = 0; j < n; ++j) r.Read(p.type, p.is_float, p.is_signed);
        }
    }
  }
  return m;
}

MeshData ParseObj(std::string_view text, const std::string& where) {
  MeshData m;
  std::vector<Vec2> vt;
  std::vector<std::array<int, 2>> corners;  // (v, vt or -1) per triangle corner, 3 per face
  size_t pos = 0;
  std::vector<std::array<int, 2>> poly;
  for (int line_no = 1; pos < text.size(); ++line_no) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const auto w = Words(text.substr(pos, nl - pos));
    pos = nl + 1;
    if (w.empty()) continue;
    const std::string at = where + ":" + std::to_string(line_no);
    if (w[0] == "v" || w[0] == "vt") {
      const size_t need = w[0] == "v" ? 3 : 1;
      double x[3] = {0, 0, 0};
      if (w.size() < need + 1)
        throw Error(at + ": '" + std::string(w[0]) + "' needs " + std::to_string(need) + " numbers");
      for (size_t k = 0; k < std::min<size_t>(3, w.size() - 1); ++k) {
        const auto v = Number(w[k + 1]);
        if (!v) throw Error(at + ": '" + std::string(w[k + 1].substr(0, 40)) + "' is not a number");
        x[k] = *v;
      }
      if (w[0] == "v")
        m.V.emplace_back(x[0], x[1], x[2]);
      else
        vt.emplace_back(x[0], x[1]);
    } else if (w[0] == "f") {
      if (w.size() < 4) throw Error(at + ": a face needs at least 3 vertices");
      poly.clear();
      for (size_t k = 1; k < w.size(); ++k) {
        const std::string_view c = w[k];
        const size_t s1 = c.find('/');
        const int v = ObjIndex(c.substr(0, s1), m.V.size(), at);
        int t = -1;
        if (s1 != std::string_view::npos) {
          const size_t s2 = c.find('/', s1 + 1);
          const std::string_view ts = c.substr(s1 + 1, s2 == std::string_view::npos ? s2 : s2 - s1 - 1);
          if (!ts.empty()) t = ObjIndex(ts, vt.size(), at);
        }
        poly.push_back({v, t});
      }
      for (size_t k = 1; k + 1 < poly.size(); ++k) {
        m.F.push_back({poly[0][0], poly[k][0], poly[k + 1][0]});
        corners.insert(corners.end(), {poly[0], poly[k], poly[k + 1]});
      }
    }
    // Everything else (vn, vp, l, p, g, o, s, usemtl, mtllib, comments) carries no geometry we use.
  }
  // uv per vertex when every use of a vertex names the same texture coordinate.
  std::vector<int> vt_of(m.V.size(), -1);
  bool uv_ok = !vt.empty();
  for (const auto& [v, t] : corners) {
    if (!uv_ok) break;
    const bool in_range = v < static_cast<int>(m.V.size()) && t >= 0 && t < static_cast<int>(vt.size());
    if (in_range && vt_of[v] < 0)
      vt_of[v] = t;
    else if (!in_range || vt[vt_of[v]] != vt[t])
      uv_ok = false;
  }
  if (uv_ok) {
    m.uv.resize(m.V.size(), Vec2::Zero());
    for (size_t v = 0; v < m.V.size(); ++v)
      if (vt_of[v] >= 0) m.uv[v] = vt[vt_of[v]];
  }
  return m;
}

namespace {

// Walks the node tree (node transforms applied), fans polygons, skips points and lines.
MeshData FromScene(const aiScene* sc, const std::string& where) {
  MeshData m;
  bool all_uv = true;
  std::vector<std::pair<const aiNode*, aiMatrix4x4>> stack{{sc->mRootNode, sc->mRootNode->mTransformation}};
  while (!stack.empty()) {
    const auto [node, xf] = stack.back();
    stack.pop_back();
    if (stack.size() > 100000) throw Error(where + ": scene graph too large");
    for (unsigned c = node->mNumChildren; c-- > 0;)
      stack.emplace_back(node->mChildren[c], xf * node->mChildren[c]->mTransformation);
    for (unsigned k = 0; k < node->mNumMeshes; ++k) {
      if (node->mMeshes[k] >= sc->mNumMeshes) throw Error(where + ": node names a mesh that does not exist");
      const aiMesh* mesh = sc->mMeshes[node->mMeshes[k]];
      const int base = static_cast<int>(m.V.size());
      all_uv &= mesh->mTextureCoords[0] != nullptr;
      for (unsigned i = 0; i < mesh->mNumVertices; ++i) {
        const aiVector3D p = xf * mesh->mVertices[i];
        m.V.emplace_back(p.x, p.y, p.z);
        if (mesh->mTextureCoords[0]) m.uv.emplace_back(mesh->mTextureCoords[0][i].x, mesh->mTextureCoords[0][i].y);
      }
      for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
        const aiFace& face = mesh->mFaces[f];
        for (unsigned j = 0; j < face.mNumIndices; ++j)
          if (face.mIndices[j] >= mesh->mNumVertices)
            throw Error(where + ": face " + std::to_string(f) + " names vertex " + std::to_string(face.mIndices[j]) +
                        " of " + std::to_string(mesh->mNumVertices));
        for (unsigned j = 1; j + 1 < face.mNumIndices; ++j)
          m.F.push_back({base + static_cast<int>(face.mIndices[0]), base + static_cast<int>(face.mIndices[j]),
                         base + static_cast<int>(face.mIndices[j + 1])});
      }
    }
  }
  if (!all_uv || m.uv.size() != m.V.size()) m.uv.clear();
  return m;
}

// Only the validation step: it reports malformed scenes as errors instead of letting
// later code walk them.
constexpr unsigned kAssimpFlags = aiProcess_ValidateDataStructure;

// Leaves in `importer` only the loaders of the file's extension. assimp otherwise falls
// back to guessing the format from the content when those loaders decline a file, so
// a damaged .glb that looks like OBJ text went to assimp's OBJ loader, which crashed on
// it (found by fuzz/fuzz_mesh; the file is in fuzz/corpus/mesh and mesh_read_test).
void OnlyLoadersFor(Assimp::Importer& importer, std::string ext, const std::string& where) {
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::vector<Assimp::BaseImporter*> others;
  bool found = false;
  for (size_t i = 0; i < importer.GetImporterCount(); ++i) {
    Assimp::BaseImporter* loader = importer.GetImporter(i);
    std::set<std::string> exts;
    loader->GetExtensionList(exts);
    if (exts.count(ext))
      found = true;
    else
      others.push_back(loader);
  }
  if (ext.empty() || ext == "ply" || ext == "obj" || !found)
    throw Error(where + ": cannot read mesh: no reader for '." + ext + "' files");
  for (Assimp::BaseImporter* loader : others) {
    importer.UnregisterLoader(loader);
    delete loader;  // unregistered loaders are no longer the importer's to delete
  }
}

// A GLB's lengths must fit in the file: assimp's glTF loaders allocate what the chunk
// header says before reading, so a damaged length asked for 4 GB (found by
// fuzz/fuzz_mesh: garments/testdata/assimp-oom-glb-chunk.glb).
void CheckGlbLengths(std::string_view b, const std::string& where) {
  auto u32 = [&](size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, b.data() + at, 4);
    return v;  // little-endian, as this machine
  };
  const auto bad = [&](const std::string& what) { throw Error(where + ": cannot read mesh: damaged GLB: " + what); };
  if (b.size() < 20 || b.substr(0, 4) != "glTF") bad("no GLB header");
  if (u32(8) != b.size())
    bad("header length " + std::to_string(u32(8)) + " but " + std::to_string(b.size()) + " bytes");
  if (u32(4) == 1) {  // glTF 1.0 binary: one content block after the 20-byte header
    if (u32(12) > b.size() - 20) bad("content length " + std::to_string(u32(12)) + " beyond the file");
    return;
  }
  for (size_t at = 12; at < b.size(); at += 8 + static_cast<size_t>(u32(at))) {
    if (b.size() - at < 8 || u32(at) > b.size() - at - 8)
      bad("chunk at byte " + std::to_string(at) + " beyond the file");
  }
}

}  // namespace

MeshData ReadWithAssimp(const std::filesystem::path& path) {
  Assimp::Importer importer;
  const std::string ext = path.extension().string();
  OnlyLoadersFor(importer, ext.empty() ? "" : ext.substr(1), path.string());
  if (path.extension() == ".glb" || path.extension() == ".GLB") CheckGlbLengths(ReadFile(path), path.string());
  const aiScene* sc = importer.ReadFile(path.string(), kAssimpFlags);
  if (!sc || !sc->mRootNode) throw Error(path.string() + ": cannot read mesh: " + importer.GetErrorString());
  return FromScene(sc, path.string());
}

MeshData ParseWithAssimp(std::string_view bytes, const std::string& hint, const std::string& where) {
  Assimp::Importer importer;
  OnlyLoadersFor(importer, hint, where);
  if (hint == "glb") CheckGlbLengths(bytes, where);
  const aiScene* sc = importer.ReadFileFromMemory(bytes.data(), bytes.size(), kAssimpFlags, hint.c_str());
  if (!sc || !sc->mRootNode) throw Error(where + ": cannot read mesh: " + importer.GetErrorString());
  return FromScene(sc, where);
}

void CheckMeshData(const MeshData& m, const std::string& where) {
  for (size_t i = 0; i < m.V.size(); ++i)
    if (!m.V[i].allFinite()) throw Error(where + ": vertex " + std::to_string(i) + " has a non-finite coordinate");
  for (size_t f = 0; f < m.F.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (m.F[f][k] < 0 || m.F[f][k] >= static_cast<int>(m.V.size()))
        throw Error(where + ": face " + std::to_string(f) + " names vertex " + std::to_string(m.F[f][k]) +
                    " (the file has " + std::to_string(m.V.size()) + " vertices)");
}

namespace {

// True when two vertices share a position (== on each coordinate, so -0 and 0 agree):
// one pass through an open-addressing table of the positions' bit patterns, so a mesh
// without repeats (every mesh drape writes) costs O(n) instead of a sort.
bool AnyRepeatedPosition(const std::vector<Vec3>& V) {
  size_t cap = 16;
  while (cap < 2 * V.size()) cap *= 2;
  std::vector<int> slot(cap, -1);
  auto bits = [](double x) { return std::bit_cast<uint64_t>(x + 0.0); };  // -0 + 0 = +0
  for (size_t i = 0; i < V.size(); ++i) {
    uint64_t h = bits(V[i].x()) * 0x9e3779b97f4a7c15ull;
    h = (h ^ bits(V[i].y())) * 0xff51afd7ed558ccdull;
    h = (h ^ bits(V[i].z())) * 0xc4ceb9fe1a85ec53ull;
    for (size_t k = (h ^ (h >> 29)) & (cap - 1);; k = (k + 1) & (cap - 1)) {
      if (slot[k] < 0) {
        slot[k] = static_cast<int>(i);
        break;
      }
      if (V[slot[k]] == V[i]) return true;
    }
  }
  return false;
}

}  // namespace

void JoinIdenticalPositions(MeshData& m) {
  const size_t n = m.V.size();
  if (!AnyRepeatedPosition(m.V)) return;
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  auto less = [&](int a, int b) {
    const Vec3 &p = m.V[a], &q = m.V[b];
    if (p.x() != q.x()) return p.x() < q.x();
    if (p.y() != q.y()) return p.y() < q.y();
    return p.z() < q.z();
  };
  std::stable_sort(order.begin(), order.end(), less);  // equal positions stay in file order
  std::vector<int> rep(n);
  bool any = false;
  for (size_t i = 0; i < n; ++i) {
    const bool same = i > 0 && !less(order[i - 1], order[i]);
    rep[order[i]] = same ? rep[order[i - 1]] : order[i];
    any |= same;
  }
  if (!any) return;
  std::vector<int> index(n, -1);
  MeshData out;
  bool uv_ok = m.uv.size() == n;
  for (size_t i = 0; i < n; ++i) {
    if (rep[i] == static_cast<int>(i)) {
      index[i] = static_cast<int>(out.V.size());
      out.V.push_back(m.V[i]);
      if (uv_ok) out.uv.push_back(m.uv[i]);
    } else if (uv_ok && m.uv[i] != m.uv[rep[i]]) {
      uv_ok = false;
    }
  }
  if (!uv_ok) out.uv.clear();
  out.F = std::move(m.F);
  for (auto& f : out.F)
    for (int& v : f) v = index[rep[v]];
  m = std::move(out);
}

}  // namespace drape
