// Subcommand registry for the `drape` binary: `drape NAME [args...]`, parsed by CLI11.
// A cmd_*.cpp file defines one or more commands with
//   static drape::cli::Register reg({"name", "one-line summary", Setup});
// where Setup declares the command's options on its CLI11 subcommand (cli/options.h has
// the spellings every command shares) and returns what runs it once the line parsed.
#pragma once

#include <CLI/App.hpp>
#include <functional>
#include <string>
#include <vector>

namespace drape::cli {

// Runs a parsed command; returns the exit status. Throws drape::Error for bad input
// (printed as "drape NAME: message", exit status 1).
using Runner = std::function<int()>;

struct Command {
  std::string name;     // e.g. "garments", "build"
  std::string summary;  // one line for `drape --help`
  // Declares the options on `app` (the command's subcommand), binding them to state the
  // returned Runner reads.
  std::function<Runner(CLI::App& app)> setup;
};

std::vector<Command>& Registry();

struct Register {
  explicit Register(Command c) { Registry().push_back(std::move(c)); }
};

}  // namespace drape::cli
