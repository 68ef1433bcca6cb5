#include "cli/options.h"

#include <CLI/Option.hpp>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "common/format.h"

namespace drape::cli {
namespace {

// "N" when min == max, "an integer >= min", "... in min..max".
std::string IntegerRange(long long min, long long max) {
  if (max == std::numeric_limits<int>::max() || max >= 1000000000) return "an integer >= " + std::to_string(min);
  return "an integer in " + std::to_string(min) + ".." + std::to_string(max);
}

// The 64-bit seed: decimal digits only, no sign, no silent clamp.
const CLI::Validator kSeed(
    [](std::string& s) -> std::string {
      uint64_t v = 0;
      const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
      if (s.empty() || r.ec != std::errc() || r.ptr != s.data() + s.size())
        return "'" + s + "' is not a seed (an integer from 0 to 18446744073709551615)";
      return "";
    },
    "");

}  // namespace

CLI::Validator IntegerIn(long long min, long long max) {
  return CLI::Validator(
      [min, max](std::string& s) -> std::string {
        long long v = 0;
        const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
        if (s.empty() || r.ec != std::errc() || r.ptr != s.data() + s.size() || v < min || v > max)
          return "'" + s + "' is not " + IntegerRange(min, max);
        return "";
      },
      "", "integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
}

CLI::Validator NumberIn(double min, double max) {
  return CLI::Validator(
      [min, max](std::string& s) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (s.empty() || *end != '\0' || !std::isfinite(v) || v < min || v > max) {
          std::string range = max == std::numeric_limits<double>::infinity()
                                  ? ">= " + FormatNumber(min)
                                  : "in [" + FormatNumber(min) + ", " + FormatNumber(max) + "]";
          return "'" + s + "' is not a number " + range;
        }
        return "";
      },
      "");
}

CLI::Option* AddOutput(CLI::App& app, std::string& path, const std::string& what) {
  return app.add_option("-o,--output", path, what)->type_name("PATH");
}

CLI::Option* AddSeed(CLI::App& app, uint64_t& seed, const std::string& what) {
  return app.add_option("--seed", seed, what)->type_name("S")->check(kSeed)->capture_default_str();
}

CLI::Option* AddJobs(CLI::App& app, int& jobs, const std::string& what) {
  return app.add_option("-j,--jobs", jobs, what)->type_name("N")->check(IntegerIn(1, std::numeric_limits<int>::max()));
}

CLI::Option* AddJson(CLI::App& app, bool& json) { return app.add_flag("--json", json, "print the result as JSON"); }

CLI::Option* AddWeights(CLI::App& app, std::string& spec) {
  return app
      .add_option("--weights", spec,
                  "weights.json, or 'none' for Eq. match only (default: RELEASE/calibration/weights.json if present)")
      ->type_name("PATH");
}

CLI::Option* AddCount(CLI::App& app, const std::string& name, int& value, const std::string& what, int min, int max) {
  return app.add_option(name, value, what)->type_name("N")->check(IntegerIn(min, max))->capture_default_str();
}

CLI::App* ParsedSubcommand(const CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands())
    if (sub->parsed()) return sub;
  return nullptr;
}

}  // namespace drape::cli
