#include "runtime/recognition/matcher.h"

#include <bit>
#include <climits>
#include <ctime>
#include <sstream>

#include "common/error.h"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define DRAPE_X86 1
#endif

namespace drape::recognition {

double WeightedDistanceReference(const Code& x, int k, const Code& q, const std::vector<double>& w, bool query_frame) {
  DRAPE_CHECK(x.SameShape(q), "feature shapes differ");
  DRAPE_CHECK(static_cast<int>(w.size()) == x.NumBits(), "weight vector size");
  const Code a = query_frame ? Rotate(x, k) : x;
  const Code b = query_frame ? q : Rotate(q, -k);
  double sum = 0;
  for (int i = 0; i < x.NumBits(); ++i) {
    if (a.Get(i) != b.Get(i)) sum += w[i];
  }
  return sum;
}

const char* WeightFrameName(WeightFrame f) { return f == WeightFrame::kQuery ? "query" : "database"; }

WeightFrame ParseWeightFrame(const std::string& name) {
  if (name == "database") return WeightFrame::kDatabase;
  if (name == "query") return WeightFrame::kQuery;
  throw Error("unknown weight frame '" + name + "' (expected database or query)");
}

const char* KernelName(Kernel k) {
  switch (k) {
    case Kernel::kAuto:
      return "auto";
    case Kernel::kGeneric:
      return "generic";
    case Kernel::kPopcnt:
      return "popcnt";
    case Kernel::kAvx512:
      return "avx512-vpopcntdq";
  }
  return "?";
}

bool KernelAvailable(Kernel k) {
  switch (k) {
    case Kernel::kAuto:
    case Kernel::kGeneric:
      return true;
#ifdef DRAPE_X86
    case Kernel::kPopcnt:
      return __builtin_cpu_supports("popcnt");
    case Kernel::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vpopcntdq");
#else
    default:
      return false;
#endif
  }
  return false;
}

Kernel ResolveKernel(Kernel k) {
  if (k != Kernel::kAuto) return k;
  if (KernelAvailable(Kernel::kAvx512)) return Kernel::kAvx512;
  if (KernelAvailable(Kernel::kPopcnt)) return Kernel::kPopcnt;
  return Kernel::kGeneric;
}

static int PadWords(int words) { return (words + 7) / 8 * 8; }

PreparedQuery::PreparedQuery(const Code& q) : q_(q) {
  q.Check("query feature");
  padded_words_ = PadWords(q.NumWords());
  rot_.assign(size_t(q.sectors) * padded_words_, 0);
  for (int k = 0; k < q.sectors; ++k) {
    const Code r = Rotate(q, -k);
    std::copy(r.words.begin(), r.words.end(), rot_.begin() + size_t(k) * padded_words_);
  }
}

PreparedWeights::PreparedWeights(const std::vector<double>& w, int layers, int rings, int sectors, WeightFrame frame)
    : w_(w), bits_(layers * rings * sectors), frame_(frame) {
  DRAPE_CHECK(static_cast<int>(w.size()) == bits_, "weight vector size");
  if (frame == WeightFrame::kDatabase) {
    table_ = w;
    return;
  }
  table_.resize(size_t(sectors) * bits_);
  for (int k = 0; k < sectors; ++k) {
    for (int b = 0; b < bits_; ++b) table_[size_t(k) * bits_ + b] = w[RotatedBit(b, sectors, k)];
  }
}

Matcher::Matcher(int layers, int rings, int sectors, Kernel kernel)
    : layers_(layers), rings_(rings), sectors_(sectors) {
  ZeroFeature(layers, rings, sectors).Check("matcher");
  words_ = (layers * rings * sectors + 63) / 64;
  padded_words_ = PadWords(words_);
  set_kernel(kernel);
}

void Matcher::set_kernel(Kernel k) {
  if (!KernelAvailable(k))
    throw Error(std::string("matching kernel '") + KernelName(k) + "' is not supported by this CPU");
  kernel_ = ResolveKernel(k);
}

int Matcher::Add(const Code& x, const std::string& where) {
  x.Check(where);
  if (x.layers != layers_ || x.rings != rings_ || x.sectors != sectors_) {
    std::ostringstream os;
    os << where << ": feature shape " << x.layers << "x" << x.rings << "x" << x.sectors
       << " differs from the database's " << layers_ << "x" << rings_ << "x" << sectors_;
    throw Error(os.str());
  }
  data_.resize(data_.size() + padded_words_, 0);
  std::copy(x.words.begin(), x.words.end(), data_.end() - padded_words_);
  return n_++;
}

namespace {

// The three kernels share one shape: for each entry, for each rotation k, the XOR
// popcount over the padded row against R_{-k} q; keep the smallest k attaining the min.
void MatchGeneric(const uint64_t* data, int n, int pw, int sectors, const PreparedQuery& q, Match* out) {
  for (int i = 0; i < n; ++i) {
    const uint64_t* x = data + size_t(i) * pw;
    Match best{INT_MAX, 0};
    for (int k = 0; k < sectors; ++k) {
      const uint64_t* r = q.rotation(k);
      int d = 0;
      for (int w = 0; w < pw; ++w) d += std::popcount(x[w] ^ r[w]);
      if (d < best.distance) best = {d, k};
    }
    out[i] = best;
  }
}

#ifdef DRAPE_X86
__attribute__((target("popcnt"))) void MatchPopcnt(const uint64_t* data, int n, int pw, int sectors,
                                                   const PreparedQuery& q, Match* out) {
  for (int i = 0; i < n; ++i) {
    const uint64_t* x = data + size_t(i) * pw;
    Match best{INT_MAX, 0};
    for (int k = 0; k < sectors; ++k) {
      const uint64_t* r = q.rotation(k);
      // Four independent accumulators hide POPCNT's latency.
      long long d0 = 0, d1 = 0, d2 = 0, d3 = 0;
      for (int w = 0; w < pw; w += 4) {
        d0 += __builtin_popcountll(x[w] ^ r[w]);
        d1 += __builtin_popcountll(x[w + 1] ^ r[w + 1]);
        d2 += __builtin_popcountll(x[w + 2] ^ r[w + 2]);
        d3 += __builtin_popcountll(x[w + 3] ^ r[w + 3]);
      }
      const int d = static_cast<int>(d0 + d1 + d2 + d3);
      if (d < best.distance) best = {d, k};
    }
    out[i] = best;
  }
}

// gcc 12's own avx512fintrin.h: _mm512_reduce_add_epi64 extracts a half through
// _mm256_undefined_si256(), which -Wmaybe-uninitialized reports once inlined here (gcc
// bug 105593, fixed in 12.3; Debian 12 has 12.2). Only that warning, only around this
// function (clang has no such warning).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
__attribute__((target("avx512f,avx512vpopcntdq"))) void MatchAvx512(const uint64_t* data, int n, int pw, int sectors,
                                                                    const PreparedQuery& q, Match* out) {
  for (int i = 0; i < n; ++i) {
    const uint64_t* x = data + size_t(i) * pw;
    Match best{INT_MAX, 0};
    for (int k = 0; k < sectors; ++k) {
      const uint64_t* r = q.rotation(k);
      __m512i acc = _mm512_setzero_si512();
      for (int w = 0; w < pw; w += 8) {
        const __m512i a = _mm512_loadu_si512(reinterpret_cast<const void*>(x + w));
        const __m512i b = _mm512_loadu_si512(reinterpret_cast<const void*>(r + w));
        acc = _mm512_add_epi64(acc, _mm512_popcnt_epi64(_mm512_xor_si512(a, b)));
      }
      const int d = static_cast<int>(_mm512_reduce_add_epi64(acc));
      if (d < best.distance) best = {d, k};
    }
    out[i] = best;
  }
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
#endif

}  // namespace

void Matcher::MatchAll(const PreparedQuery& q, std::vector<Match>* out) const {
  const Code& c = q.code();
  if (c.layers != layers_ || c.rings != rings_ || c.sectors != sectors_) {
    std::ostringstream os;
    os << "query feature shape " << c.layers << "x" << c.rings << "x" << c.sectors << " differs from the database's "
       << layers_ << "x" << rings_ << "x" << sectors_;
    throw Error(os.str());
  }
  DRAPE_CHECK(q.padded_words() == padded_words_, "padding");
  out->resize(n_);
  if (n_ == 0) return;
  switch (kernel_) {
#ifdef DRAPE_X86
    case Kernel::kAvx512:
      MatchAvx512(data_.data(), n_, padded_words_, sectors_, q, out->data());
      return;
    case Kernel::kPopcnt:
      MatchPopcnt(data_.data(), n_, padded_words_, sectors_, q, out->data());
      return;
#endif
    default:
      MatchGeneric(data_.data(), n_, padded_words_, sectors_, q, out->data());
  }
}

double Matcher::Weighted(int i, const PreparedQuery& q, int k, const PreparedWeights& w) const {
  DRAPE_CHECK(i >= 0 && i < n_, "entry index");
  const uint64_t* x = row(i);
  const uint64_t* r = q.rotation(k);
  const double* t = w.rotation(k);
  double sum = 0;
  for (int wi = 0; wi < words_; ++wi) {
    uint64_t m = x[wi] ^ r[wi];
    while (m) {
      sum += t[wi * 64 + std::countr_zero(m)];
      m &= m - 1;
    }
  }
  return sum;
}

void Matcher::XorVector(int i, const PreparedQuery& q, int k, WeightFrame frame, std::vector<double>* out) const {
  const int bits = layers_ * rings_ * sectors_;
  out->assign(bits, 0.0);
  const uint64_t* x = row(i);
  const uint64_t* r = q.rotation(k);
  for (int wi = 0; wi < words_; ++wi) {
    uint64_t m = x[wi] ^ r[wi];
    while (m) {
      const int b = wi * 64 + std::countr_zero(m);
      (*out)[frame == WeightFrame::kQuery ? RotatedBit(b, sectors_, k) : b] = 1.0;
      m &= m - 1;
    }
  }
}

}  // namespace drape::recognition
