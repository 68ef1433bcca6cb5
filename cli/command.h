// Subcommand registry for the `drape` binary: `drape NAME [args...]`.
// A cmd_*.cpp file defines one or more commands with
//   static drape::cli::Register reg({"name", "one-line summary", usage, Run});
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace drape::cli {

struct Command {
  std::string name;     // e.g. "garments", "build"
  std::string summary;  // one line for `drape --help`
  std::string usage;    // full help text for `drape NAME --help`
  // Receives the arguments after the command name. Returns the exit status.
  // Throws drape::Error for bad input (printed as "drape NAME: message", exit 1).
  std::function<int(const std::vector<std::string>&)> run;
};

std::vector<Command>& Registry();

struct Register {
  explicit Register(Command c) { Registry().push_back(std::move(c)); }
};

}  // namespace drape::cli
