#include "cli/app.h"

#include <CLI/CLI.hpp>  // the whole library once: CLI11 is header-only (Config.hpp defines ConfigBase)
#include <algorithm>
#include <exception>

#include "cli/options.h"
#include "common/error.h"
#include "common/version.h"

namespace drape::cli {

std::vector<Command>& Registry() {
  static std::vector<Command> commands;
  return commands;
}

namespace {

std::string VersionLine() { return std::string("drape ") + DRAPE_VERSION + " (" + GitVersion() + ")"; }

// Runs `run`, turning exceptions into the house's messages and exit statuses.
template <typename F>
int Guarded(const std::string& name, std::ostream& err, F&& run) {
  try {
    return run();
  } catch (const Error& e) {
    err << "drape " << name << ": " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    err << "drape " << name << ": internal error: " << e.what() << "\n";
    return 3;
  }
}

// CLI11's message for a failed parse. Its leftover-argument message (2.1.2) joins the
// leftovers last first (it expects them as parse() takes them): they are named here in
// the order they were given.
std::string ParseMessage(const CLI::App& app, const CLI::ParseError& e) {
  const std::vector<std::string> extras = app.remaining(true);
  if (!dynamic_cast<const CLI::ExtrasError*>(&e) || extras.empty()) return e.what();
  std::string m =
      extras.size() > 1 ? "The following arguments were not expected:" : "The following argument was not expected:";
  for (const std::string& a : extras) m += " " + a;
  return m;
}

}  // namespace

DrapeApp MakeApp() {
  DrapeApp d;
  d.app = std::make_unique<CLI::App>(
      "Builds versioned databases of simulated garments and runs the algorithms that use them.", "drape");
  CLI::App& app = *d.app;
  app.set_version_flag("--version", VersionLine());
  app.get_formatter()->column_width(28);
  app.footer("drape COMMAND --help shows a command's options.");
  std::vector<Command> commands = Registry();
  std::sort(commands.begin(), commands.end(), [](auto& a, auto& b) { return a.name < b.name; });
  for (const Command& c : commands) {
    CLI::App* sub = app.add_subcommand(c.name, c.summary);
    d.runners[c.name] = c.setup(*sub);
  }
  return d;
}

int RunDrape(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  DrapeApp d = MakeApp();
  if (args.empty()) {
    out << d.app->help();
    return 2;
  }
  // The command named on the line with its subcommands ("garments make"), for the error
  // prefix (parsing may fail before CLI11 marks them parsed).
  std::string name;
  const CLI::App* at = d.app.get();
  for (const std::string& a : args) {
    const auto subs = at->get_subcommands([&](const CLI::App* s) { return s->get_name() == a; });
    if (subs.empty()) break;
    at = subs.front();
    name += (name.empty() ? "" : " ") + a;
  }
  try {
    std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them last first
    d.app->parse(reversed);
  } catch (const CLI::CallForHelp&) {
    out << d.app->help();
    return 0;
  } catch (const CLI::CallForVersion&) {
    out << VersionLine() << "\n";
    return 0;
  } catch (const CLI::ParseError& e) {
    err << "drape" << (name.empty() ? "" : " " + name) << ": " << ParseMessage(*d.app, e) << " (see drape " << name
        << (name.empty() ? "" : " ") << "--help)\n";
    return 1;
  }
  const CLI::App* sub = ParsedSubcommand(*d.app);
  if (!sub) {
    out << d.app->help();
    return 2;
  }
  return Guarded(name, err, d.runners.at(sub->get_name()));
}

}  // namespace drape::cli
