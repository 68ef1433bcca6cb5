// The `drape` command line: every registered command (cli/command.h) as a CLI11
// subcommand, parsed and run with the house's error conventions.
#pragma once

#include <CLI/App.hpp>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "cli/command.h"

namespace drape::cli {

struct DrapeApp {
  std::unique_ptr<CLI::App> app;
  std::map<std::string, Runner> runners;  // by command name
};

// A fresh command line with every registered command declared on it.
DrapeApp MakeApp();

// `drape ARGS...` (ARGS without the program name): parses, runs the command and returns
// the exit status. Help goes to `out` (status 0); bad input, on the line or found while
// running, is "drape COMMAND: message" on `err` (status 1); no command prints the list
// (status 2); an unexpected failure is "internal error" (status 3).
int RunDrape(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace drape::cli
