// recipes/README.md's key tables against the parser's own tables (keys.cpp), and the
// key tables against the parser: every key a table lists is accepted, its field set.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include "common/error.h"
#include "common/files.h"
#include "common/source_dir.h"
#include "generator/recipe/recipe.h"

namespace fs = std::filesystem;
namespace drape {
namespace {

// The README block of one section: between "<!-- keys: NAME -->" and "<!-- /keys -->".
std::string Block(const std::string& readme, const std::string& name, bool* found) {
  const std::string open = "<!-- keys: " + name + " -->\n", close = "<!-- /keys -->";
  const size_t a = readme.find(open);
  *found = a != std::string::npos;
  if (!*found) return "";
  const size_t b = readme.find(close, a);
  return readme.substr(a + open.size(), b == std::string::npos ? std::string::npos : b - a - open.size());
}

TEST(RecipeKeys, ReadmeTablesAreTheParsersTables) {
  const std::string readme = ReadFile(SourceDir() / "recipes/README.md");
  std::set<std::string> names;
  for (const auto& section : RecipeKeyDocs()) {
    names.insert(section.name);
    bool found = false;
    const std::string got = Block(readme, section.name, &found);
    const std::string want = RecipeKeysMarkdown(section);
    EXPECT_TRUE(found) << "recipes/README.md has no block <!-- keys: " << section.name << " -->";
    EXPECT_EQ(got, want) << "recipes/README.md's table for '" << section.name
                         << "' differs from generator/recipe/keys.cpp; the table should read:\n"
                         << want;
  }
  // No stale block for a section that no longer exists.
  for (size_t at = readme.find("<!-- keys: "); at != std::string::npos; at = readme.find("<!-- keys: ", at + 1)) {
    const size_t end = readme.find(" -->", at);
    const std::string name = readme.substr(at + 11, end - at - 11);
    EXPECT_TRUE(names.count(name)) << "recipes/README.md has a block for unknown section '" << name << "'";
  }
}

// A Validate() error is placed at the key that set the field, through the
// FieldError's field address: also for keys inside sub-maps and for fields of nested
// structs; a field no key set is reported at its section.
TEST(RecipeKeys, ValidateErrorsArePlacedAtTheirKey) {
  const std::string head = "name: x\nversion: 1.0.0\nseed: 1\n";
  const std::string tail = "garments:\n  - template: towel\n    materials: [towel_a]\n";
  auto error = [&](const std::string& middle) {
    try {
      ParseRecipe(head + middle + tail, "r.yaml", SourceDir());
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("simulation:\n  settle: {distance: 0.002, window: 0.001}\n"),
            "r.yaml:5:37: simulation.settle.window: must be in [4 time steps, 100] s");
  EXPECT_EQ(error("sensing:\n  sensed:\n    camera: {fx: -1}\n"),
            "r.yaml:6:18: sensing.sensed.camera.fx: must be in (0, 1e5] px");
  EXPECT_EQ(error("simulation: {min_time: 20}\n"),
            "r.yaml:4:13: simulation: time_cap: must exceed min_time + settle_window and be at most 3600 s");
  EXPECT_EQ(error("feature: {sectors: 65}\n"), "r.yaml:4:20: feature.sectors: must be in [1, 64]");
  EXPECT_EQ(error("feature: {origin: centre}\n"),
            "r.yaml:4:19: feature.origin: must be top_layer or grip, not 'centre'");
  EXPECT_EQ(error("feature: {origin: grip}\n"), "");
}

}  // namespace
}  // namespace drape
