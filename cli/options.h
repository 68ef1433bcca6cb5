// The options every `drape` command spells the same way, and the checks on numbers.
// One spelling per concept: -o/--output, --seed (an integer >= 0), -j/--jobs (>= 1),
// --json, --config FILE (the research options file, cli/config.h). Every number is range
// checked when the line is parsed, with an error that names the option.
#pragma once

#include <CLI/App.hpp>
#include <CLI/Validators.hpp>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <utility>

#include "common/field_error.h"

namespace drape::cli {

// -o/--output PATH. `what` says what is written there (the help text).
CLI::Option* AddOutput(CLI::App& app, std::string& path, const std::string& what);
// --seed S: a 64-bit unsigned seed (0 … 2^64−1, as releases record them).
CLI::Option* AddSeed(CLI::App& app, uint64_t& seed, const std::string& what);
// -j/--jobs N (>= 1). `what` says what runs side by side.
CLI::Option* AddJobs(CLI::App& app, int& jobs, const std::string& what);
// --json: print the result as JSON instead of text.
CLI::Option* AddJson(CLI::App& app, bool& json);
// --weights PATH|none: learned weights for recognition (resolved by
// recognition::ResolveWeightsPath: "" = the release's own calibration if present).
CLI::Option* AddWeights(CLI::App& app, std::string& spec);

// An integer option in [min, max], e.g. AddCount(app, "--trials", trials, "trials per
// category", 1). The default shown in --help is `value`'s.
CLI::Option* AddCount(CLI::App& app, const std::string& name, int& value, const std::string& what, int min = 1,
                      int max = 1000000000);

// A validator: an integer in [min, max] ("--trials: '0' is not an integer >= 1"), named
// "integer in [min, max]" (cli_test reads the range back).
CLI::Validator IntegerIn(long long min, long long max);
// A validator: a finite number in [min, max].
CLI::Validator NumberIn(double min, double max);

// Runs `o.Validate()`; a FieldError (common/field_error.h) for a field that one of
// `fields` (field address, option name) set is rethrown as a drape::Error naming the
// option: "--edge-length: must be in [0.005, 0.2] m, got 0.3". The struct's own ranges
// stay the only ones.
template <typename O>
void ValidateOptions(const O& o, std::initializer_list<std::pair<const void*, const char*>> fields) {
  try {
    o.Validate();
  } catch (const FieldError& e) {
    for (const auto& [field, name] : fields)
      if (field == e.field()) throw Error(std::string(name) + ": " + e.reason());
    throw;
  }
}

// The subcommand that was parsed among `app`'s, or null.
CLI::App* ParsedSubcommand(const CLI::App& app);

}  // namespace drape::cli
