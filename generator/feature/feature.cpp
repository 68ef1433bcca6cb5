#include "generator/feature/feature.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/error.h"
#include "common/field_error.h"

namespace drape {

namespace {

constexpr int kMaxDim = 1024;

void CheckSameShape(const Feature& a, const Feature& b) {
  if (a.layers != b.layers || a.rings != b.rings || a.sectors != b.sectors)
    throw Error("Distance: features of different shapes (" + std::to_string(a.layers) + "x" + std::to_string(a.rings) +
                "x" + std::to_string(a.sectors) + " vs " + std::to_string(b.layers) + "x" + std::to_string(b.rings) +
                "x" + std::to_string(b.sectors) + ")");
  DRAPE_CHECK(a.words.size() == size_t(a.NumWords()) && b.words.size() == a.words.size(), "feature word count");
}

uint64_t LowMask(int n) { return n >= 64 ? ~uint64_t(0) : (uint64_t(1) << n) - 1; }

// The Φ bits of ring group g (= l·R + r).
uint64_t GetGroup(const Feature& f, int g) {
  const int phi = f.sectors;
  const int bit = g * phi, w = bit / 64, o = bit % 64;
  uint64_t v = f.words[w] >> o;
  if (o + phi > 64) v |= f.words[w + 1] << (64 - o);
  return v & LowMask(phi);
}

void SetGroup(Feature& f, int g, uint64_t v) {
  const int phi = f.sectors;
  const int bit = g * phi, w = bit / 64, o = bit % 64;
  const uint64_t m = LowMask(phi);
  f.words[w] = (f.words[w] & ~(m << o)) | (v << o);
  if (o + phi > 64) {
    const int hi = o + phi - 64;
    f.words[w + 1] = (f.words[w + 1] & ~LowMask(hi)) | (v >> (64 - o));
  }
}

// Circular shift of a Φ-bit ring towards higher sectors by k ∈ [0, Φ).
uint64_t RotateGroup(uint64_t v, int k, int phi) {
  if (k == 0) return v;
  return ((v << k) | (v >> (phi - k))) & LowMask(phi);
}

void PutU32(std::string& s, uint32_t v) {
  for (int i = 0; i < 4; ++i) s.push_back(char((v >> (8 * i)) & 0xff));
}
uint32_t GetU32(std::string_view s, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(uint8_t(s[at + i])) << (8 * i);
  return v;
}

}  // namespace

void FeatureOptions::Validate() const {
  if (layers < 1 || layers > kMaxDim) BadField(layers, "FeatureOptions.layers", "must be in [1, 1024]");
  if (rings < 1 || rings > kMaxDim) BadField(rings, "FeatureOptions.rings", "must be in [1, 1024]");
  if (sectors < 1 || sectors > 64) BadField(sectors, "FeatureOptions.sectors", "must be in [1, 64]");
  if (int64_t(layers) * rings * sectors > (int64_t(1) << 24))
    throw Error("FeatureOptions: layers·rings·sectors must be at most 2^24 bits");
  if (origin != "top_layer" && origin != "grip")
    BadField(origin, "FeatureOptions.origin", "must be top_layer or grip, not '" + origin + "'");
}

bool Feature::Get(int l, int r, int s) const {
  DRAPE_CHECK(l >= 0 && l < layers && r >= 0 && r < rings && s >= 0 && s < sectors, "cell index");
  const int i = Index(l, r, s, rings, sectors);
  return (words[i / 64] >> (i % 64)) & 1;
}

void Feature::Set(int l, int r, int s, bool value) {
  DRAPE_CHECK(l >= 0 && l < layers && r >= 0 && r < rings && s >= 0 && s < sectors, "cell index");
  const int i = Index(l, r, s, rings, sectors);
  const uint64_t bit = uint64_t(1) << (i % 64);
  words[i / 64] = value ? (words[i / 64] | bit) : (words[i / 64] & ~bit);
}

void Feature::Set(int bit, bool value) {
  const uint64_t m = uint64_t(1) << (bit & 63);
  words[bit >> 6] = value ? (words[bit >> 6] | m) : (words[bit >> 6] & ~m);
}

void Feature::Check(const std::string& where) const {
  const std::string shape = std::to_string(layers) + "x" + std::to_string(rings) + "x" + std::to_string(sectors);
  try {
    FeatureOptions{layers, rings, sectors}.Validate();
  } catch (const Error& e) {
    throw Error(where + ": invalid feature shape " + shape + ": " + e.what());
  }
  if (int(words.size()) != NumWords())
    throw Error(where + ": feature of shape " + shape + " needs " + std::to_string(NumWords()) + " 64-bit words, has " +
                std::to_string(words.size()));
  const int used = NumBits() % 64;
  if (used != 0 && (words.back() & ~LowMask(used)) != 0)
    throw Error(where + ": feature has bits set beyond its last cell");
}

Feature ZeroFeature(int layers, int rings, int sectors) {
  Feature f;
  f.layers = layers;
  f.rings = rings;
  f.sectors = sectors;
  f.words.assign(f.NumWords(), 0);
  return f;
}

int Feature::PopCount() const {
  int n = 0;
  for (uint64_t w : words) n += __builtin_popcountll(w);
  return n;
}

FeatureFrame ComputeFeatureFrame(const Points3& P, const FeatureOptions& opt) {
  opt.Validate();
  if (P.rows() == 0) throw Error("ExtractFeature: no surface points");
  if (!P.allFinite()) throw Error("ExtractFeature: surface points must be finite");
  FeatureFrame fr;
  const double y_max = P.col(1).maxCoeff(), y_min = P.col(1).minCoeff();
  const double height = y_max - y_min;
  if (!(height > 0)) throw Error("ExtractFeature: surface points have no vertical extent");
  fr.y_max = y_max;
  fr.layer_height = height / opt.layers;
  // Origin: mean (x, z) of the top layer's points (Algorithm 1); "grip" keeps (0, 0).
  if (opt.origin == "top_layer") {
    double sx = 0, sz = 0;
    int n = 0;
    for (Eigen::Index i = 0; i < P.rows(); ++i) {
      if (y_max - P(i, 1) < fr.layer_height) {
        sx += P(i, 0);
        sz += P(i, 2);
        ++n;
      }
    }
    DRAPE_CHECK(n > 0, "the top point is in the top layer");
    fr.origin_x = sx / n;
    fr.origin_z = sz / n;
  }
  double r2 = 0;
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    r2 = std::max(r2, std::pow(P(i, 0) - fr.origin_x, 2) + std::pow(P(i, 2) - fr.origin_z, 2));
  fr.r_max = std::sqrt(r2);
  if (!(fr.r_max > 0)) throw Error("ExtractFeature: surface points have no horizontal extent");
  return fr;
}

Vec3 CellCentre(const FeatureFrame& fr, const FeatureOptions& opt, int l, int r, int s) {
  const double y = fr.y_max - (l + 0.5) * fr.layer_height;
  const double rho = (r + 0.5) * fr.r_max / opt.rings;
  const double phi = (s + 0.5) * 2 * M_PI / opt.sectors;
  return Vec3(fr.origin_x + rho * std::cos(phi), y, fr.origin_z - rho * std::sin(phi));
}

Feature ExtractFeature(const Points3& P, const SdfFunction& sdf, const FeatureOptions& opt) {
  if (!sdf) throw Error("ExtractFeature: no SDF");
  const FeatureFrame fr = ComputeFeatureFrame(P, opt);
  Feature f;
  f.layers = opt.layers;
  f.rings = opt.rings;
  f.sectors = opt.sectors;
  f.words.assign(f.NumWords(), 0);
  for (int l = 0; l < opt.layers; ++l)
    for (int r = 0; r < opt.rings; ++r)
      for (int s = 0; s < opt.sectors; ++s)
        if (sdf(CellCentre(fr, opt, l, r, s)) <= 0) f.Set(l, r, s, true);
  return f;
}

Feature Rotate(const Feature& f, int k) {
  const int phi = f.sectors;
  k = ((k % phi) + phi) % phi;
  Feature out = f;
  for (int g = 0; g < f.layers * f.rings; ++g) SetGroup(out, g, RotateGroup(GetGroup(f, g), k, phi));
  return out;
}

Feature Mirror(const Feature& f) {
  Feature out = f;
  for (int l = 0; l < f.layers; ++l)
    for (int r = 0; r < f.rings; ++r)
      for (int s = 0; s < f.sectors; ++s) out.Set(l, r, f.sectors - 1 - s, f.Get(l, r, s));
  return out;
}

int RotatedBit(int bit, int sectors, int k) {
  const int lr = bit / sectors, s = bit % sectors;
  return lr * sectors + ((s + k) % sectors + sectors) % sectors;
}

Match DistanceReference(const Feature& a, const Feature& b) {
  CheckSameShape(a, b);
  Match best{std::numeric_limits<int>::max(), 0};
  for (int k = 0; k < a.sectors; ++k) {
    int d = 0;
    for (int l = 0; l < a.layers; ++l)
      for (int r = 0; r < a.rings; ++r)
        for (int s = 0; s < a.sectors; ++s) d += a.Get(l, r, s) != b.Get(l, r, (s + k) % a.sectors);
    if (d < best.distance) best = {d, k};
  }
  return best;
}

Match Distance(const Feature& a, const Feature& b) {
  CheckSameShape(a, b);
  const int phi = a.sectors;
  const size_t nw = a.words.size();
  Match best{std::numeric_limits<int>::max(), 0};
  if (64 % phi == 0) {
    // Rings never straddle words: rotate all 64/Φ lanes of a word at once.
    uint64_t lanes = 0;
    for (int i = 0; i < 64; i += phi) lanes |= LowMask(phi) << i;
    for (int k = 0; k < phi; ++k) {
      // Per-lane masks: bits [0, k) receive the wrapped part, [k, Φ) the shifted one.
      uint64_t lo = 0;
      for (int i = 0; i < 64; i += phi) lo |= LowMask(k) << i;
      const uint64_t hi_mask = lanes & ~lo;
      int d = 0;
      for (size_t w = 0; w < nw; ++w) {
        const uint64_t x = a.words[w];
        const uint64_t r = k == 0 ? x : (((x << k) & hi_mask) | ((x >> (phi - k)) & lo));
        d += __builtin_popcountll(r ^ b.words[w]);
      }
      if (d < best.distance) best = {d, k};
    }
    return best;
  }
  // General Φ: unpack each ring into a word once, then rotate-xor-popcount.
  const int groups = a.layers * a.rings;
  std::vector<uint64_t> ga(groups), gb(groups);
  for (int g = 0; g < groups; ++g) {
    ga[g] = GetGroup(a, g);
    gb[g] = GetGroup(b, g);
  }
  for (int k = 0; k < phi; ++k) {
    int d = 0;
    for (int g = 0; g < groups; ++g) d += __builtin_popcountll(RotateGroup(ga[g], k, phi) ^ gb[g]);
    if (d < best.distance) best = {d, k};
  }
  return best;
}

std::string EncodeFeature(const Feature& f) {
  DRAPE_CHECK(f.words.size() == size_t(f.NumWords()), "feature word count");
  std::string s = "DRFT";
  PutU32(s, 1);
  PutU32(s, uint32_t(f.layers));
  PutU32(s, uint32_t(f.rings));
  PutU32(s, uint32_t(f.sectors));
  PutU32(s, uint32_t(f.words.size()));
  for (uint64_t w : f.words)
    for (int i = 0; i < 8; ++i) s.push_back(char((w >> (8 * i)) & 0xff));
  return s;
}

Feature DecodeFeature(std::string_view s, const std::string& where) {
  auto bad = [&](const std::string& what) -> Error { return Error(where + ": feature: " + what); };
  if (s.size() < 24) throw bad("truncated header (" + std::to_string(s.size()) + " bytes)");
  if (s.substr(0, 4) != "DRFT") throw bad("bad magic (not a drape feature file)");
  const uint32_t version = GetU32(s, 4);
  if (version != 1) throw bad("unsupported version " + std::to_string(version));
  const uint32_t n = GetU32(s, 8), r = GetU32(s, 12), phi = GetU32(s, 16), nw = GetU32(s, 20);
  FeatureOptions o;
  o.layers = int(std::min<uint32_t>(n, 1u << 30));
  o.rings = int(std::min<uint32_t>(r, 1u << 30));
  o.sectors = int(std::min<uint32_t>(phi, 1u << 30));
  try {
    o.Validate();
  } catch (const Error& e) {
    throw bad(std::string("bad shape: ") + e.what());
  }
  Feature f;
  f.layers = o.layers;
  f.rings = o.rings;
  f.sectors = o.sectors;
  if (nw != uint32_t(f.NumWords())) throw bad("word count " + std::to_string(nw) + " does not match the shape");
  if (s.size() != 24 + 8 * size_t(nw))
    throw bad("size " + std::to_string(s.size()) + " bytes, expected " + std::to_string(24 + 8 * size_t(nw)));
  f.words.resize(nw);
  for (uint32_t w = 0; w < nw; ++w) {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t(uint8_t(s[24 + 8 * w + i])) << (8 * i);
    f.words[w] = v;
  }
  const int used = f.NumBits() % 64;
  if (used != 0 && (f.words.back() & ~LowMask(used)) != 0) throw bad("non-zero padding bits");
  return f;
}

}  // namespace drape
