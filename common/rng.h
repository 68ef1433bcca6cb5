// Seeded random numbers. Every random draw in drape comes from an Rng seeded by
// DeriveSeed(recipe seed, job key): never from global state or the clock. The
// generators are written out here (not std:: distributions) so that a seed gives
// the same numbers with any standard library. Draw one value per statement or
// declarator (`const double x = rng.Uniform(), y = rng.Uniform();`), never several in
// the arguments of one call: `Vec3(rng.Uniform(), rng.Uniform(), rng.Uniform())` gets
// its draws in an unspecified order (gcc right to left, clang left to right), so the
// same seed would give other points with another compiler.
#pragma once

#include <cstdint>
#include <string_view>

namespace drape {

// A child seed from a parent seed and a key such as "shirt/m1/left_elbow/sweep".
uint64_t DeriveSeed(uint64_t parent, std::string_view key);

// xoshiro256** (Blackman & Vigna), seeded through splitmix64.
class Rng {
 public:
  explicit Rng(uint64_t seed);
  uint64_t NextU64();
  // Uniform in [0, 1).
  double Uniform();
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Standard normal (Marsaglia polar method).
  double Normal();
  double Normal(double mean, double sigma) { return mean + sigma * Normal(); }
  // Uniform integer in [0, n).
  uint64_t Below(uint64_t n);

 private:
  uint64_t s_[4];
  bool has_spare_ = false;
  double spare_ = 0;
};

}  // namespace drape
