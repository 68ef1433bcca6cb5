// Rotation-invariant Hamming matching of many binary shape features at once (paper
// Eq. match, the word-parallel kernels of the database search) and the weighted Hamming
// distance of Eq. bestmatch.
//
// A Code is the packed feature of generator/feature (drape::Feature): N layers × R rings
// × Φ sectors, bit b = (l·R + r)·Φ + s stored in words[b / 64] at bit (b % 64), LSB
// first. Rotating the garment by 2π/Φ about the vertical axis is, per (layer, ring), a
// circular shift of the Φ sector bits: R_k = Rotate(·, k) maps sector s to (s + k) mod Φ.
// Eq. match of one pair, and its bit-by-bit reference, are generator/feature's Distance
// and DistanceReference; the kernels here are tested against them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "generator/feature/feature.h"

namespace drape::recognition {

using Code = drape::Feature;
using drape::Match;  // {min_k |R_k x ⊕ q|_1, the smallest k attaining it}

// Weighted distance of Eq. bestmatch at rotation k, computed bit by bit: in the query
// frame w^T (R_k x ⊕ q) (the paper's literal form), in the database frame
// w^T (x ⊕ R_{-k} q) (see WeightFrame).
double WeightedDistanceReference(const Code& x, int k, const Code& q, const std::vector<double>& w, bool query_frame);

// Which XOR-popcount kernel the fast matcher uses.
enum class Kernel {
  kAuto,     // best available on this CPU (AVX-512 VPOPCNTDQ, else POPCNT, else generic)
  kGeneric,  // portable std::popcount (no special instructions)
  kPopcnt,   // x86 POPCNT on 64-bit words
  kAvx512,   // AVX-512 VPOPCNTDQ on 8 words at a time
};
const char* KernelName(Kernel k);
bool KernelAvailable(Kernel k);
// kAuto → the concrete kernel this CPU uses.
Kernel ResolveKernel(Kernel k);

// A query prepared for matching: its Φ inverse rotations R_{-k} q, so that
// |R_k x ⊕ q| = |x ⊕ R_{-k} q| needs no rotation of database features at query time.
// (Equivalent to precomputing the Φ rotations of every database feature — Φ×words
// XOR-popcounts per entry either way — but keeps the database Φ times smaller and in cache.)
class PreparedQuery {
 public:
  PreparedQuery() = default;
  explicit PreparedQuery(const Code& q);
  const Code& code() const { return q_; }
  int padded_words() const { return padded_words_; }
  // words of R_{-k} q, padded with zeros to padded_words().
  const uint64_t* rotation(int k) const { return rot_.data() + size_t(k) * padded_words_; }

 private:
  Code q_;
  int padded_words_ = 0;
  std::vector<uint64_t> rot_;
};

// Which frame the weight vector w of Eq. bestmatch indexes.
//  kDatabase (default): w_b weighs bit b of (x_i ⊕ R_{-k} q), i.e. the query turned into
//    the database entry's frame. The database features are all simulated in the object
//    frame, so bit b means the same cell of every database garment, and the weighted
//    distance stays invariant to the angle at which the query's sweep started (turning q
//    by j sectors changes k by j and nothing else).
//  kQuery (the paper's literal w^T(R_k x_i ⊕ q)): w_b weighs bit b of the query frame;
//    only meaningful when every sweep starts at the same gripper angle.
enum class WeightFrame { kDatabase, kQuery };
const char* WeightFrameName(WeightFrame f);
// Throws drape::Error on an unknown name ("database" | "query").
WeightFrame ParseWeightFrame(const std::string& name);

// Per-category weights prepared for the fast weighted distance: table[k][b] is the weight
// of bit b of (x ⊕ R_{-k} q): w[b] in the database frame, w[R_k(b)] in the query frame
// (since (R_k x ⊕ q) = R_k (x ⊕ R_{-k} q)).
class PreparedWeights {
 public:
  PreparedWeights() = default;
  PreparedWeights(const std::vector<double>& w, int layers, int rings, int sectors, WeightFrame frame);
  bool empty() const { return table_.empty(); }
  const std::vector<double>& weights() const { return w_; }
  const double* rotation(int k) const {
    return frame_ == WeightFrame::kDatabase ? table_.data() : table_.data() + size_t(k) * bits_;
  }

 private:
  std::vector<double> w_;
  int bits_ = 0;
  WeightFrame frame_ = WeightFrame::kDatabase;
  std::vector<double> table_;
};

// Database features packed contiguously (each row padded to a multiple of 8 words)
// for brute-force matching.
class Matcher {
 public:
  Matcher() = default;
  Matcher(int layers, int rings, int sectors, Kernel kernel = Kernel::kAuto);

  // Appends a feature; throws drape::Error if its shape differs. Returns its index.
  int Add(const Code& x, const std::string& where);
  int size() const { return n_; }
  int layers() const { return layers_; }
  int rings() const { return rings_; }
  int sectors() const { return sectors_; }
  Kernel kernel() const { return kernel_; }
  void set_kernel(Kernel k);

  // Eq. match of q against every entry: out[i] = {min_k |R_k x_i ⊕ q|, argmin k}.
  void MatchAll(const PreparedQuery& q, std::vector<Match>* out) const;
  // Weighted distance of entry i at rotation k (Eq. bestmatch term).
  double Weighted(int i, const PreparedQuery& q, int k, const PreparedWeights& w) const;
  // Dense 0/1 vector of the bits that differ at rotation k, in the weights' frame
  // (query frame: R_k x_i ⊕ q; database frame: x_i ⊕ R_{-k} q), for calibration.
  void XorVector(int i, const PreparedQuery& q, int k, WeightFrame frame, std::vector<double>* out) const;

  const uint64_t* row(int i) const { return data_.data() + size_t(i) * padded_words_; }

 private:
  int layers_ = 0, rings_ = 0, sectors_ = 0, words_ = 0, padded_words_ = 0, n_ = 0;
  Kernel kernel_ = Kernel::kGeneric;
  std::vector<uint64_t> data_;
};

}  // namespace drape::recognition
