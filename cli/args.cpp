#include "cli/args.h"

#include <algorithm>
#include <charconv>
#include <cstdlib>

#include "common/error.h"

namespace drape::cli {

Args::Args(const std::vector<std::string>& argv, const std::vector<std::string>& flags,
           const std::vector<std::string>& options) {
  auto is = [](const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
  };
  bool only_positional = false;
  for (size_t i = 0; i < argv.size(); ++i) {
    const std::string& a = argv[i];
    if (only_positional || a.size() < 2 || a[0] != '-' ||
        (a.size() > 1 && (std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.'))) {
      positional_.push_back(a);
      continue;
    }
    if (a == "--") {
      only_positional = true;
      continue;
    }
    if (a == "--help" || a == "-h") {
      help_ = true;
      continue;
    }
    std::string name = a, value;
    bool has_value = false;
    if (const auto eq = a.find('='); eq != std::string::npos && a.rfind("--", 0) == 0) {
      name = a.substr(0, eq);
      value = a.substr(eq + 1);
      has_value = true;
    }
    // Short options glued to their value, as in "-j2" or "-oOUT".
    if (!has_value && a.size() > 2 && a[1] != '-' && is(options, a.substr(0, 2))) {
      name = a.substr(0, 2);
      value = a.substr(2);
      has_value = true;
    }
    if (is(flags, name)) {
      if (has_value) throw Error("option " + name + " takes no value");
      flags_[name] = true;
    } else if (is(options, name)) {
      if (!has_value) {
        if (i + 1 >= argv.size()) throw Error("option " + name + " needs a value");
        value = argv[++i];
      }
      values_.emplace(name, value);
    } else {
      throw Error("unknown option " + name + " (see --help)");
    }
  }
}

bool Args::Flag(const std::string& name) const { return flags_.count(name) > 0; }

std::optional<std::string> Args::Get(const std::string& name) const {
  auto range = values_.equal_range(name);
  if (range.first == range.second) return std::nullopt;
  return std::prev(range.second)->second;  // the last one wins
}

std::string Args::Get(const std::string& name, const std::string& fallback) const {
  return Get(name).value_or(fallback);
}

std::optional<double> Args::GetDouble(const std::string& name) const {
  auto v = Get(name);
  if (!v) return std::nullopt;
  char* end = nullptr;
  const double d = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0') throw Error("option " + name + ": '" + *v + "' is not a number");
  return d;
}

std::optional<long long> Args::GetInt(const std::string& name) const {
  auto v = Get(name);
  if (!v) return std::nullopt;
  long long d = 0;
  const auto r = std::from_chars(v->data(), v->data() + v->size(), d);
  if (r.ec == std::errc::result_out_of_range) throw Error("option " + name + ": '" + *v + "' is out of range");
  if (v->empty() || r.ec != std::errc() || r.ptr != v->data() + v->size())
    throw Error("option " + name + ": '" + *v + "' is not an integer");
  return d;
}

std::optional<uint64_t> Args::GetSeed(const std::string& name) const {
  auto v = Get(name);
  if (!v) return std::nullopt;
  uint64_t d = 0;
  const auto r = std::from_chars(v->data(), v->data() + v->size(), d);
  if (v->empty() || r.ec != std::errc() || r.ptr != v->data() + v->size())
    throw Error("option " + name + ": '" + *v + "' is not a seed (an integer from 0 to 18446744073709551615)");
  return d;
}

std::vector<std::string> Args::GetAll(const std::string& name) const {
  std::vector<std::string> out;
  auto range = values_.equal_range(name);
  for (auto it = range.first; it != range.second; ++it) out.push_back(it->second);
  return out;
}

void Args::RequirePositional(size_t min, size_t max, const std::string& what) const {
  if (positional_.size() < min) throw Error("missing " + what + " (see --help)");
  if (positional_.size() > max) throw Error("unexpected argument '" + positional_[max] + "' (see --help)");
}

}  // namespace drape::cli
