#include "generator/recipe/recipe.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "common/error.h"
#include "common/files.h"
#include "common/source_dir.h"

namespace fs = std::filesystem;
namespace drape {
namespace {

const fs::path kTestdata = SourceDir() / "generator/recipe/testdata";

std::string LoadError(const fs::path& p) {
  try {
    LoadRecipe(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// Every testdata/bad_*.yaml names, in its first line, the place and the message
// its error must give: "# expect: LINE:COL key.path: what".
TEST(Recipe, BadRecipesNameFileLineColumnAndKey) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(kTestdata)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("bad_", 0) != 0 || e.path().extension() != ".yaml") continue;
    ++n;
    const std::string text = ReadFile(e.path());
    std::smatch m;
    const std::string first = text.substr(0, text.find('\n'));
    ASSERT_TRUE(std::regex_match(first, m, std::regex("# expect: (\\d+:\\d+) (.*)"))) << name;
    const std::string where = e.path().string() + ":" + m[1].str() + ": ";
    const std::string what = m[2].str();
    const std::string err = LoadError(e.path());
    SCOPED_TRACE(name);
    EXPECT_EQ(err.rfind(where, 0), 0u) << "got: " << err << "\nwant prefix: " << where;
    EXPECT_NE(err.find(what), std::string::npos) << "got: " << err << "\nwant: " << what;
  }
  EXPECT_GE(n, 15);
}

// A recipe in a temporary folder.
class TempRecipe {
 public:
  explicit TempRecipe(const std::string& text) {
    dir_ = fs::temp_directory_path() /
           ("drape_recipe_test_" + std::to_string(::getpid()) + "_" + std::to_string(count_++));
    fs::create_directories(dir_);
    path_ = dir_ / "recipe.yaml";
    std::ofstream(path_) << text;
  }
  ~TempRecipe() { fs::remove_all(dir_); }
  const fs::path& path() const { return path_; }

 private:
  static inline int count_ = 0;
  fs::path dir_, path_;
};

const char* kGood = R"(
name: tiny
version: 0.2.1
seed: 7
description: a test recipe
materials:
  heavy_towel: {preset: towel_a, area_density: 0.35}
  custom: {stretch_percent: 2.0, friction_deg: 20, area_density: 0.25, bending: 0.01}
  pressed: {preset: tshirt, bending_rigidity: 2.3e-5, crease_yield: 200, crease_weakening: 2}
simulation:
  time_step: 0.005
  solver_iterations: 12
  settle: {distance: 0.002, window: 0.3}
  time_cap: 5
sensing:
  database: {frames: 40, degrees: 360, keep_frames: true, camera: {height: 1.1, distance: 1.3}}
  sensed: {frames: 30}
fusion: {voxels_per_metre: 100, truncation: 0.02, box: {min: [-0.6, -1.4, -0.6], max: [0.6, 0.1, 0.6]}}
feature: {layers: 8, rings: 8, sectors: 8}
garments:
  - template: towel
    instances: 3
    edge_length: 0.05
    materials: [towel_a, heavy_towel]
  - name: trousers
    template: pants
    size: L
    instances: 2
    materials: [custom]
splits:
  train:
    garments: [{garment: towel, instances: [0, 1]}, {garment: trousers, instances: [0]}]
  test:
    garments: [{garment: towel, instances: [2], materials: [heavy_towel], max_anchors: 2}]
    perturbation: {grasp_offset: 0.03, size_scale: [0.9, 1.1], material_jitter: 0.1}
)";

TEST(Recipe, ParsesEveryKeyIntoTypedOptions) {
  TempRecipe t(kGood);
  const Recipe r = LoadRecipe(t.path());
  EXPECT_EQ(r.name, "tiny");
  EXPECT_EQ(r.version, "0.2.1");
  EXPECT_EQ(r.seed, 7u);
  EXPECT_EQ(r.description, "a test recipe");
  EXPECT_EQ(r.text, std::string(kGood));
  EXPECT_DOUBLE_EQ(r.hang.time_step, 0.005);
  EXPECT_EQ(r.hang.solver_iterations, 12);
  EXPECT_DOUBLE_EQ(r.hang.settle_distance, 0.002);
  EXPECT_DOUBLE_EQ(r.hang.settle_window, 0.3);
  EXPECT_DOUBLE_EQ(r.hang.time_cap, 5);
  const auto& db = r.sensing.at("database");
  const auto& sensed = r.sensing.at("sensed");
  EXPECT_EQ(db.sweep.frames, 40);
  EXPECT_FALSE(db.sweep.kinect.noise);
  EXPECT_TRUE(db.keep_frames);
  EXPECT_DOUBLE_EQ(db.sweep.camera_height, 1.1);
  // sensed inherits from database, with noise on by default.
  EXPECT_EQ(sensed.sweep.frames, 30);
  EXPECT_TRUE(sensed.sweep.kinect.noise);
  EXPECT_DOUBLE_EQ(sensed.sweep.camera_distance, 1.3);
  EXPECT_DOUBLE_EQ(r.fusion.voxels_per_metre, 100);
  EXPECT_DOUBLE_EQ(r.fusion.box.min().y(), -1.4);
  EXPECT_EQ(r.feature.layers, 8);
  ASSERT_EQ(r.garments.size(), 2u);
  EXPECT_EQ(r.garments[0].name, "towel");
  EXPECT_EQ(r.garments[0].instances, 3);
  EXPECT_DOUBLE_EQ(r.garments[0].options.edge_length, 0.05);
  EXPECT_EQ(r.garments[0].anchor_labels, r.garments[0].all_anchor_labels);
  EXPECT_FALSE(r.garments[0].anchor_labels.empty());
  EXPECT_EQ(r.garments[1].name, "trousers");
  EXPECT_EQ(r.garments[1].category, "pants");
  EXPECT_EQ(r.garments[1].options.size, "L");
  EXPECT_DOUBLE_EQ(r.materials.at("heavy_towel").area_density, 0.35);
  EXPECT_DOUBLE_EQ(r.materials.at("heavy_towel").stretch_percent, FindMaterialPreset("towel_a")->stretch_percent);
  EXPECT_DOUBLE_EQ(r.materials.at("custom").bending_stiffness, 0.01);
  EXPECT_DOUBLE_EQ(r.materials.at("pressed").bending_rigidity, 2.3e-5);
  EXPECT_DOUBLE_EQ(r.materials.at("pressed").crease_yield, 200);
  EXPECT_DOUBLE_EQ(r.materials.at("pressed").crease_weakening, 2);
  EXPECT_DOUBLE_EQ(r.materials.at("heavy_towel").bending_rigidity, FindMaterialPreset("towel_a")->bending_rigidity);
  ASSERT_EQ(r.splits.size(), 2u);
  EXPECT_EQ(r.splits[0].name, "train");
  EXPECT_EQ(r.splits[0].sensing, "database");
  EXPECT_EQ(r.splits[1].name, "test");
  EXPECT_EQ(r.splits[1].sensing, "sensed");
  EXPECT_DOUBLE_EQ(r.splits[1].perturbation.grasp_offset, 0.03);
  EXPECT_DOUBLE_EQ(r.splits[1].perturbation.size_scale_min, 0.9);
  EXPECT_EQ(r.splits[1].selectors[0].max_anchors, 2);
  // trousers instance 1 is in no split.
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("trousers"), std::string::npos);
}

TEST(Recipe, AllowOutsidePathsLetsAPathLeaveTheFolder) {
  // The escape is allowed, so the next check (the file exists) is what fails.
  TempRecipe t(R"(
name: x
version: 1.0.0
seed: 1
allow_outside_paths: true
garments:
  - file: ../no_such_file_anywhere.obj
    materials: [towel_a]
)");
  const std::string err = LoadError(t.path());
  EXPECT_NE(err.find("garments[0].file: file not found"), std::string::npos) << err;
}

TEST(Recipe, AnchorSubsetMustBeLabelsOfTheTemplate) {
  const auto& labels = Templates()[0].anchor_labels;
  ASSERT_GE(labels.size(), 2u);
  TempRecipe t("name: x\nversion: 1.0.0\nseed: 1\ngarments:\n  - template: " + Templates()[0].name +
               "\n    materials: [towel_a]\n    anchors: [" + labels[1] + ", " + labels[0] + "]\n");
  const Recipe r = LoadRecipe(t.path());
  EXPECT_EQ(r.garments[0].anchor_labels, (std::vector<std::string>{labels[1], labels[0]}));
}

TEST(Recipe, SeedTakesTheWhole64BitRange) {
  TempRecipe t(
      "name: x\nversion: 1.0.0\nseed: 18446744073709551615\ngarments:\n  - template: towel\n"
      "    materials: [towel_a]\n");
  EXPECT_EQ(LoadRecipe(t.path()).seed, 18446744073709551615ull);
  for (const char* bad : {"18446744073709551616", "-1", "1.5"}) {
    TempRecipe u(std::string("name: x\nversion: 1.0.0\nseed: ") + bad +
                 "\ngarments:\n  - template: towel\n    materials: [towel_a]\n");
    EXPECT_NE(LoadError(u.path()).find(":3:7: seed: expected a non-negative integer"), std::string::npos)
        << LoadError(u.path());
  }
}

TEST(Recipe, MissingRequiredKeysAreNamed) {
  TempRecipe t("name: x\nversion: 1.0.0\ngarments:\n  - template: towel\n    materials: [towel_a]\n");
  EXPECT_NE(LoadError(t.path()).find(":1:1: seed: missing key 'seed'"), std::string::npos) << LoadError(t.path());
  TempRecipe u("name: x\nversion: 1.0.0\nseed: 3\ngarments:\n  - template: towel\n");
  EXPECT_NE(LoadError(u.path()).find(":5:5: garments[0]: missing key 'materials'"), std::string::npos)
      << LoadError(u.path());
}

// The upper caps the recipe had before ranges moved into the stages' Validate(): each
// value just past its cap is rejected at its own line and column, the cap itself is not.
TEST(Recipe, StageCapsRejectValuesPastThemAtTheirKey) {
  struct Case {
    std::string section, bad, good, where;
  };
  const std::vector<Case> cases = {
      {"sensing:\n  database:\n    camera:\n      image_width: ", "8193", "8192",
       ":7:20: sensing.database.camera.image_width"},
      {"sensing:\n  database:\n    camera:\n      image_height: ", "4", "8",
       ":7:21: sensing.database.camera.image_height"},
      {"sensing:\n  database:\n    camera:\n      look_at_height: ", "10.5", "-10",
       ":7:23: sensing.database.camera.look_at_height"},
      {"fusion:\n  voxels_per_metre: 10\n  truncation: ", "1.5", "1", ":6:15: fusion.truncation"},
      {"fusion:\n  frames_stride: ", "100001", "100000", ":5:18: fusion.frames_stride"},
      {"fusion:\n  carve_min_views: ", "100001", "100000", ":5:20: fusion.carve_min_views"},
  };
  const std::string head = "name: x\nversion: 1.0.0\nseed: 3\n";
  const std::string tail = "\ngarments:\n  - template: towel\n    materials: [towel_a]\n";
  for (const auto& c : cases) {
    SCOPED_TRACE(c.where);
    TempRecipe bad(head + c.section + c.bad + tail);
    const std::string err = LoadError(bad.path());
    EXPECT_NE(err.find(c.where), std::string::npos) << err;
    TempRecipe good(head + c.section + c.good + tail);
    EXPECT_EQ(LoadError(good.path()), "");
  }
}

}  // namespace
}  // namespace drape
