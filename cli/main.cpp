// drape: build garment databases and run the algorithms that use them.
#include <algorithm>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "cli/command.h"
#include "common/error.h"
#include "common/version.h"

namespace drape::cli {
std::vector<Command>& Registry() {
  static std::vector<Command> commands;
  return commands;
}
}  // namespace drape::cli

namespace {

void PrintHelp() {
  auto cmds = drape::cli::Registry();
  std::sort(cmds.begin(), cmds.end(), [](auto& a, auto& b) { return a.name < b.name; });
  std::cout << "drape " << DRAPE_VERSION << " (" << drape::GitVersion() << ")\n"
            << "Builds versioned databases of simulated garments and runs the algorithms "
               "that use them.\n\nUsage: drape COMMAND [ARGS...]   (drape COMMAND --help for more)\n\n"
               "Commands:\n";
  for (const auto& c : cmds) {
    std::cout << "  " << c.name << std::string(c.name.size() < 12 ? 12 - c.name.size() : 1, ' ') << c.summary << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    PrintHelp();
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::cout << "drape " << DRAPE_VERSION << " (" << drape::GitVersion() << ")\n";
    return 0;
  }
  const auto& cmds = drape::cli::Registry();
  auto it = std::find_if(cmds.begin(), cmds.end(), [&](auto& c) { return c.name == args[0]; });
  if (it == cmds.end()) {
    std::cerr << "drape: unknown command '" << args[0] << "' (see drape --help)\n";
    return 2;
  }
  try {
    return it->run(std::vector<std::string>(args.begin() + 1, args.end()));
  } catch (const drape::Error& e) {
    std::cerr << "drape " << it->name << ": " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "drape " << it->name << ": internal error: " << e.what() << "\n";
    return 3;
  }
}
