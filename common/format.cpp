#include "common/format.h"

#include <charconv>

namespace drape {

std::string FormatNumber(double x) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

}  // namespace drape
