// Errors and invariant checks shared by every stage.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace drape {

// Bad input (a recipe, a mesh file, a command-line argument). The message names
// where (file:line:col, field, entry) and what; callers print it as is.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A numerical failure inside one job (simulation blew up, solver diverged).
// Caught per job: the entry is marked failed with this reason.
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace detail {
[[noreturn]] inline void CheckFailed(const char* file, int line, const char* expr, const std::string& msg) {
  std::ostringstream os;
  os << "internal check failed at " << file << ":" << line << ": " << expr;
  if (!msg.empty()) os << " (" << msg << ")";
  throw std::logic_error(os.str());
}
}  // namespace detail

}  // namespace drape

// Internal invariant; stays on in release builds. Use drape::Error for bad input.
#define DRAPE_CHECK(cond, msg)                                                   \
  do {                                                                           \
    if (!(cond)) ::drape::detail::CheckFailed(__FILE__, __LINE__, #cond, (msg)); \
  } while (0)
