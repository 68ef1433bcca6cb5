// SHA-256 (OpenSSL) for file hashes, SHA256SUMS and release digests.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace drape {

// Incremental SHA-256; HexDigest() finishes it (lower-case hex, 64 chars).
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  Sha256& Update(std::string_view bytes);
  std::string HexDigest();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

std::string Sha256Hex(std::string_view bytes);
// Throws drape::Error naming the path if it cannot be read.
std::string Sha256File(const std::filesystem::path& path);

}  // namespace drape
