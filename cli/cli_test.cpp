// Walks every `drape` command: at most 12 options in each --help, the spellings every
// command shares, an undeclared flag fails, a negative seed and a count below its range
// fail naming the option; and the options file (cli/config.h) is strict and documented.
#include <gtest/gtest.h>

#include <CLI/Option.hpp>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>

#include "cli/app.h"
#include "cli/config.h"
#include "common/error.h"
#include "common/files.h"
#include "common/source_dir.h"

namespace drape::cli {
namespace {

namespace fs = std::filesystem;

struct Leaf {
  std::vector<std::string> path;  // e.g. {"garments", "make"}
  CLI::App* app;
};

// Every command that runs: the subcommands without subcommands of their own.
void CollectLeaves(CLI::App* app, const std::vector<std::string>& path, std::vector<Leaf>& out) {
  const std::vector<CLI::App*> subs = app->get_subcommands([](CLI::App*) { return true; });
  if (subs.empty() && !path.empty()) {
    out.push_back({path, app});
    return;
  }
  for (CLI::App* sub : subs) {
    std::vector<std::string> p = path;
    p.push_back(sub->get_name());
    CollectLeaves(sub, p, out);
  }
}

struct Outcome {
  int status;
  std::string out, err;
};

Outcome Drape(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int status = RunDrape(args, out, err);
  return {status, out.str(), err.str()};
}

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : " ") + x;
  return s;
}

// The command's path followed by a placeholder for each required positional and each
// required option's value (so that only the error under test remains).
std::vector<std::string> WithRequired(const Leaf& leaf) {
  std::vector<std::string> args = leaf.path;
  for (const CLI::Option* o : leaf.app->get_options()) {
    if (!o->get_required()) continue;
    if (o->nonpositional()) args.push_back(o->get_name(false, true).substr(0, o->get_name(false, true).find(',')));
    for (int k = 0; k < std::max(1, o->get_expected_min()); ++k) args.push_back("x");
  }
  return args;
}

// The option's validator named "integer in [min, max]" (cli/options.h IntegerIn), if any.
bool IntegerRange(CLI::Option* op, long long* min, long long* max) {
  for (int i = 0;; ++i) {
    const CLI::Validator* v = nullptr;
    try {
      v = op->get_validator(i);
    } catch (const CLI::OptionNotFound&) {
      return false;
    }
    if (std::sscanf(v->get_name().c_str(), "integer in [%lld, %lld]", min, max) == 2) return true;
  }
}

class Commands : public ::testing::Test {
 protected:
  void SetUp() override {
    d_ = MakeApp();
    CollectLeaves(d_.app.get(), {}, leaves_);
  }
  DrapeApp d_;
  std::vector<Leaf> leaves_;
};

TEST_F(Commands, EveryCommandIsFound) {
  std::set<std::string> names;
  for (const Leaf& l : leaves_) names.insert(Join(l.path));
  for (const char* c : {"build", "garments list", "garments make", "garments show", "info", "ls", "verify", "merge",
                        "register", "recognize", "calibrate", "eval", "unfold", "fold", "fabric cantilever",
                        "fabric drape", "fabric incline", "fabric crease"})
    EXPECT_TRUE(names.count(c)) << c;
}

TEST_F(Commands, EveryHelpShowsAtMost12Options) {
  for (const Leaf& l : leaves_) {
    std::vector<std::string> args = l.path;
    args.push_back("--help");
    const Outcome o = Drape(args);
    EXPECT_EQ(o.status, 0) << Join(args) << ": " << o.err;
    EXPECT_NE(o.out.find("Usage: drape " + Join(l.path)), std::string::npos) << o.out;
    const auto options = l.app->get_options([](const CLI::Option* op) { return op->nonpositional(); });
    EXPECT_LE(options.size(), 12u) << Join(l.path) << "'s --help shows " << options.size() << " options:\n" << o.out;
    // Each is in the help text.
    for (const CLI::Option* op : options)
      EXPECT_NE(o.out.find(op->get_name(false, true)), std::string::npos) << op->get_name(false, true);
  }
}

TEST_F(Commands, SharedSpellingsAgree) {
  // One spelling per concept: these others are not used.
  const std::set<std::string> banned = {"--out",     "--outdir", "--report", "--threads",     "--thread",
                                        "--workers", "-t",       "-s",       "--random-seed", "--unweighted"};
  for (const Leaf& l : leaves_) {
    for (const CLI::Option* op : l.app->get_options()) {
      if (!op->nonpositional()) continue;
      const std::vector<std::string> snames = op->get_snames(), lnames = op->get_lnames();
      std::set<std::string> names;
      for (const auto& s : snames) names.insert("-" + s);
      for (const auto& s : lnames) names.insert("--" + s);
      const std::string where = Join(l.path) + " " + op->get_name(false, true);
      for (const auto& n : names) EXPECT_FALSE(banned.count(n)) << where;
      if (names.count("-o") || names.count("--output")) {
        EXPECT_EQ(names, (std::set<std::string>{"-o", "--output"})) << where;
      }
      if (names.count("-j") || names.count("--jobs")) {
        EXPECT_EQ(names, (std::set<std::string>{"-j", "--jobs"})) << where;
      }
      if (names.count("--json")) {
        EXPECT_EQ(op->get_expected_max(), 0) << where << " must be a flag";
      }
      if (names.count("--seed") || names.count("--config")) {
        EXPECT_EQ(names.size(), 1u) << where;
      }
    }
  }
}

TEST_F(Commands, AnUndeclaredFlagFailsNamingIt) {
  for (const Leaf& l : leaves_) {
    std::vector<std::string> args = WithRequired(l);
    args.push_back("--no-such-flag");
    const Outcome o = Drape(args);
    EXPECT_EQ(o.status, 1) << Join(args);
    EXPECT_NE(o.err.find("--no-such-flag"), std::string::npos) << o.err;
    EXPECT_EQ(o.err.rfind("drape " + Join(l.path) + ": ", 0), 0u) << o.err;
  }
}

TEST_F(Commands, LeftoverArgumentsAreNamedInTheOrderGiven) {
  const Outcome one = Drape({"info", "release", "first", "second", "third"});
  EXPECT_EQ(one.status, 1);
  EXPECT_NE(one.err.find("not expected: first second third (see drape info --help)"), std::string::npos) << one.err;
  const Outcome top = Drape({"no-such-command", "another"});
  EXPECT_EQ(top.status, 1);
  EXPECT_NE(top.err.find("not expected: no-such-command another (see"), std::string::npos) << top.err;
  const Outcome single = Drape({"info", "release", "extra"});
  EXPECT_NE(single.err.find("argument was not expected: extra (see"), std::string::npos) << single.err;
}

TEST_F(Commands, ANegativeSeedAndACountBelowItsRangeFailNamingTheOption) {
  int seeds = 0, counts = 0;
  for (const Leaf& l : leaves_) {
    for (CLI::Option* op : l.app->get_options([](const CLI::Option* o) { return o->nonpositional(); })) {
      const std::string name = op->get_name(false, true);
      const std::string lname = op->get_lnames().empty() ? name : "--" + op->get_lnames().front();
      std::vector<std::string> bad;
      if (lname == "--seed") {
        ++seeds;
        bad = {"-1", "18446744073709551616", "1.5"};
      }
      long long min = 0, max = 0;
      if (IntegerRange(op, &min, &max)) {
        ++counts;
        bad = {std::to_string(min - 1), "2.5", "x"};
        if (min >= 1) bad.push_back("0");
      }
      for (const std::string& value : bad) {
        std::vector<std::string> args = WithRequired(l);
        args.push_back(lname);
        args.push_back(value);
        const Outcome o = Drape(args);
        EXPECT_EQ(o.status, 1) << Join(args);
        EXPECT_NE(o.err.find(lname + ": '" + value + "'"), std::string::npos) << Join(args) << ": " << o.err;
      }
    }
  }
  EXPECT_GE(seeds, 1);   // garments make
  EXPECT_GE(counts, 1);  // build -j, verify -j
}

TEST(OptionsFile, EverySectionAndKeyIsChecked) {
  auto error = [](const std::string& text) {
    try {
      OptionsFile::Parse(text, "opts.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error(""), "");
  EXPECT_EQ(error("registration:\n  kappa: 2e-4\n"), "");
  EXPECT_EQ(error(R"({"registration": {"grid_cells": 32}})"), "");
  EXPECT_EQ(error("registraton:\n  kappa: 1\n")
                .rfind("opts.yaml:1:1: registraton: unknown key (did you mean "
                       "'registration'?)",
                       0),
            0u)
      << error("registraton:\n  kappa: 1\n");
  EXPECT_EQ(error("registration:\n  kapa: 1\n")
                .rfind("opts.yaml:2:3: registration.kapa: unknown key (did you mean "
                       "'kappa'?)",
                       0),
            0u);
  EXPECT_EQ(error("registration:\n  grid_cells: 1.5\n"),
            "opts.yaml:2:15: registration.grid_cells: expected an integer, got '1.5'");
  const std::string range = error("registration:\n  grid_cells: -3\n");
  EXPECT_EQ(range.rfind("opts.yaml:2:15: registration.grid_cells: ", 0), 0u) << range;
}

TEST(OptionsFile, DocsListEverySectionAsTheTablesSay) {
  const std::string doc = ReadFile(SourceDir() / "docs/options.md");
  const std::string close = "<!-- /options -->";
  std::string want = OptionsFileMarkdown();
  want = want.substr(0, want.rfind(close) + close.size());
  const size_t a = doc.find("<!-- options: ");
  const size_t b = doc.rfind(close);
  ASSERT_NE(a, std::string::npos) << "docs/options.md has no generated section tables";
  const std::string got = doc.substr(a, b + close.size() - a);
  EXPECT_EQ(got, want) << "docs/options.md's tables differ from the commands' key tables; they should read:\n" << want;
}

}  // namespace
}  // namespace drape::cli
