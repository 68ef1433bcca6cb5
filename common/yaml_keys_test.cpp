#include "common/yaml_keys.h"

#include <gtest/gtest.h>

#include "common/yaml.h"

namespace drape {
namespace {

struct Knobs {
  int count = 2;
  double radius = 0.5;
  bool on = true;
  std::string mode = "fast";
  void Validate() const {
    if (count < 1) BadField(count, "count", "must be >= 1");
    if (mode != "fast" && mode != "slow") BadField(mode, "mode", "must be fast or slow");
  }
};

const std::vector<OptionKey<Knobs>>& Table() {
  static const std::vector<OptionKey<Knobs>> t = {
      {"count", Ref(&Knobs::count), "", "how many"},
      {"radius", Ref(&Knobs::radius), "m", "how far"},
      {"on", Ref(&Knobs::on), "bool", "whether"},
      {"mode", Ref(&Knobs::mode), "name", "fast or slow"},
  };
  return t;
}

// The error message of reading `text` into Knobs, or "" when it reads.
std::string ReadError(const std::string& text, Knobs* out = nullptr) {
  try {
    const YamlKeyReader r("knobs.yaml");
    const YAML::Node n = LoadYaml(text, "knobs.yaml");
    Knobs k;
    r.Validate(k, n, "knobs", r.Keys(n, "knobs", Table(), k));
    if (out) *out = k;
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(YamlKeys, ReadsKnownKeysFromYamlAndJson) {
  Knobs k;
  EXPECT_EQ(ReadError("count: 3\nradius: 0.25\non: false\nmode: slow\n", &k), "");
  EXPECT_EQ(k.count, 3);
  EXPECT_EQ(k.radius, 0.25);
  EXPECT_FALSE(k.on);
  EXPECT_EQ(k.mode, "slow");
  EXPECT_EQ(ReadError(R"({"count": 4, "on": true})", &k), "");
  EXPECT_EQ(k.count, 4);
  EXPECT_EQ(k.radius, 0.5);  // untouched keys keep their defaults
}

TEST(YamlKeys, ErrorsNameFileLineColumnAndKey) {
  EXPECT_EQ(ReadError("count: 3\nradious: 1\n"),
            "knobs.yaml:2:1: knobs.radious: unknown key (did you mean 'radius'?); known keys here: count, radius, on, "
            "mode");
  EXPECT_EQ(ReadError("count: 0\n"), "knobs.yaml:1:8: knobs.count: must be >= 1");
  EXPECT_EQ(ReadError("count: 1.5\n"), "knobs.yaml:1:8: knobs.count: expected an integer, got '1.5'");
  EXPECT_EQ(ReadError("radius: [1]\n"), "knobs.yaml:1:9: knobs.radius: expected a number, got a list");
  EXPECT_EQ(ReadError("on: yes\n"), "knobs.yaml:1:5: knobs.on: expected true or false, got 'yes'");
  EXPECT_EQ(ReadError("count: 1\ncount: 2\n"), "knobs.yaml:2:1: knobs.count: key given twice");
  EXPECT_EQ(ReadError("mode: medium\n"), "knobs.yaml:1:7: knobs.mode: must be fast or slow");
  EXPECT_EQ(ReadError("[1, 2]\n"), "knobs.yaml:1:1: knobs: expected a mapping, got a list");
}

TEST(YamlKeys, DocumentsTheTableWithItsDefaults) {
  Knobs defaults;
  const OptionSectionDoc d = KeysDoc("knobs", Table(), &defaults);
  EXPECT_EQ(KeysMarkdown(d),
            "| key | default | unit | meaning |\n|---|---|---|---|\n"
            "| `count` | `2` |  | how many |\n| `radius` | `0.5` | m | how far |\n"
            "| `on` | `true` | bool | whether |\n| `mode` | `fast` | name | fast or slow |\n");
}

TEST(YamlKeys, EditDistance) {
  EXPECT_EQ(EditDistance("", ""), 0);
  EXPECT_EQ(EditDistance("seed", "sede"), 2);
  EXPECT_EQ(EditDistance("instnces", "instances"), 1);
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3);
  EXPECT_EQ(Suggest("sede", {"seed", "name"}), " (did you mean 'seed'?)");
  EXPECT_EQ(Suggest("xyzzy", {"seed", "name"}), "");
}

}  // namespace
}  // namespace drape
