// A small strict argument parser: options must be declared, unknown ones are errors.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace drape::cli {

class Args {
 public:
  // `flags`: options without a value (e.g. "--json"); `options`: options taking a
  // value ("-o", "--size"), given as "--size M" or "--size=M". Throws drape::Error
  // naming an unknown option or a missing value. "--help"/"-h" sets help().
  Args(const std::vector<std::string>& argv, const std::vector<std::string>& flags,
       const std::vector<std::string>& options);

  bool help() const { return help_; }
  bool Flag(const std::string& name) const;
  std::optional<std::string> Get(const std::string& name) const;
  std::string Get(const std::string& name, const std::string& fallback) const;
  // Numeric accessors throw drape::Error naming the option on a malformed number.
  std::optional<double> GetDouble(const std::string& name) const;
  std::optional<long long> GetInt(const std::string& name) const;
  // A 64-bit unsigned seed (0 … 2^64−1, as releases record them); anything else throws.
  std::optional<uint64_t> GetSeed(const std::string& name) const;
  // All values of an option given several times, in order.
  std::vector<std::string> GetAll(const std::string& name) const;
  const std::vector<std::string>& positional() const { return positional_; }
  // Throws drape::Error unless min <= #positional <= max.
  void RequirePositional(size_t min, size_t max, const std::string& what) const;

 private:
  bool help_ = false;
  std::map<std::string, bool> flags_;
  std::multimap<std::string, std::string> values_;
  std::vector<std::string> positional_;
};

}  // namespace drape::cli
