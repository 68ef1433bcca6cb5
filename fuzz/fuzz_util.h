// Shared helpers for the libFuzzer targets (fuzz/README.md).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "common/error.h"
#include "common/files.h"

namespace drape {
namespace fs = std::filesystem;
}

namespace drape::fuzz {

inline std::string_view Bytes(const uint8_t* data, size_t size) { return {reinterpret_cast<const char*>(data), size}; }

// A scratch folder of this process (readers that take paths get their input here).
inline const std::filesystem::path& Scratch() {
  static const std::filesystem::path dir = [] {
    const auto d = std::filesystem::temp_directory_path() / ("drape_fuzz_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

// Runs a reader: drape::Error is the expected answer to bad input; any other
// exception escaping a reader is a bug (libFuzzer reports the abort as a crash).
template <class F>
void ExpectOnlyDrapeErrors(F&& f) {
  try {
    f();
  } catch (const Error&) {
  }
}

// Splits one input into parts at a separator line (lets one input carry several files).
inline std::vector<std::string> SplitParts(std::string_view in, std::string_view sep = "\n--8<--\n") {
  std::vector<std::string> out;
  size_t pos = 0;
  for (;;) {
    const size_t k = in.find(sep, pos);
    out.emplace_back(in.substr(pos, k == std::string_view::npos ? std::string_view::npos : k - pos));
    if (k == std::string_view::npos) return out;
    pos = k + sep.size();
  }
}

}  // namespace drape::fuzz
