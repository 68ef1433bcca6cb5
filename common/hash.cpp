#include "common/hash.h"

#include <openssl/evp.h>

#include <fstream>
#include <vector>

#include "common/error.h"

namespace drape {

struct Sha256::Impl {
  EVP_MD_CTX* ctx = nullptr;
  bool done = false;
};

Sha256::Sha256() : impl_(std::make_unique<Impl>()) {
  impl_->ctx = EVP_MD_CTX_new();
  DRAPE_CHECK(impl_->ctx && EVP_DigestInit_ex(impl_->ctx, EVP_sha256(), nullptr) == 1, "EVP_DigestInit_ex");
}

Sha256::~Sha256() { EVP_MD_CTX_free(impl_->ctx); }

Sha256& Sha256::Update(std::string_view bytes) {
  DRAPE_CHECK(!impl_->done, "Update after HexDigest");
  DRAPE_CHECK(EVP_DigestUpdate(impl_->ctx, bytes.data(), bytes.size()) == 1, "EVP_DigestUpdate");
  return *this;
}

std::string Sha256::HexDigest() {
  DRAPE_CHECK(!impl_->done, "HexDigest called twice");
  impl_->done = true;
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  DRAPE_CHECK(EVP_DigestFinal_ex(impl_->ctx, md, &len) == 1, "EVP_DigestFinal_ex");
  static const char* hex = "0123456789abcdef";
  std::string out(size_t{2} * len, '0');
  for (size_t i = 0; i < len; ++i) {
    out[2 * i] = hex[md[i] >> 4];
    out[2 * i + 1] = hex[md[i] & 15];
  }
  return out;
}

std::string Sha256Hex(std::string_view bytes) { return Sha256().Update(bytes).HexDigest(); }

std::string Sha256File(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open for reading");
  Sha256 h;
  std::vector<char> buf(1 << 16);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    h.Update(std::string_view(buf.data(), static_cast<size_t>(in.gcount())));
  }
  return h.HexDigest();
}

}  // namespace drape
