// Feature fixtures shared by the recognition tests (header-only; tests only).
#pragma once

#include <cstdint>
#include <string>
#include <utility>

#include "common/rng.h"
#include "generator/feature/feature.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

// A uniformly random 8 layers × 8 rings × 16 sectors feature from rng.
inline Feature RandomFeature(Rng& rng) {
  Feature f;
  f.layers = 8;
  f.rings = 8;
  f.sectors = 16;
  f.words.assign(16, 0);
  for (auto& w : f.words) w = rng.NextU64();
  return f;
}

// The same from a fresh generator seeded with `seed`.
inline Feature RandomFeature(uint64_t seed) {
  Rng rng(seed);
  return RandomFeature(rng);
}

// A layers × rings × sectors feature whose bits are set with probability p.
inline Feature RandomCode(Rng& rng, int layers, int rings, int sectors, double p = 0.5) {
  Feature c = ZeroFeature(layers, rings, sectors);
  for (int b = 0; b < c.NumBits(); ++b) c.Set(b, rng.Uniform() < p);
  return c;
}

// f with `flips` bits drawn at random (with repeats) inverted.
inline Feature FlipBits(Feature f, Rng& rng, int flips) {
  for (int i = 0; i < flips; ++i) {
    const int b = static_cast<int>(rng.Below(f.NumBits()));
    f.Set(b, !f.Get(b));
  }
  return f;
}

// A labelled database entry or query (split "train"; height 0 = unknown).
inline LabelledCode Labelled(const std::string& id, const std::string& category, const std::string& instance,
                             const std::string& anchor, Code code, double height = 0) {
  LabelledCode lc;
  lc.label.id = id;
  lc.label.split = "train";
  lc.label.category = category;
  lc.label.instance = instance;
  lc.label.anchor = anchor;
  lc.label.height = height;
  lc.code = std::move(code);
  return lc;
}

}  // namespace drape::recognition
