// The garment as drape unfold leaves it: written and read back (from the trial folder,
// its placed.json or its trace.json).
#include "runtime/folding/placed.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "common/error.h"
#include "common/files.h"
#include "garments/templates.h"
#include "runtime/tabletop/table.h"

namespace drape::folding {
namespace {
namespace fs = std::filesystem;

Garment Shirt() {
  TemplateOptions o;
  o.edge_length = 0.05;
  return MakeGarment("long_sleeve_shirt", o);
}

class PlacedFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("drape_placed_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(PlacedFiles, RoundTripFromTheTrialFolderItsPlacedJsonAndItsTrace) {
  PlacedGarment p;
  p.garment = Shirt();
  tabletop::TableOptions high;
  high.top = 0.75;
  p.lying = tabletop::LayFlat(p.garment.mesh, high, Vec2(0.1, 0.2), 2.0);
  p.material = "tshirt";
  p.stiffness = 0.21;
  p.friction = 0.45;
  WritePlacedGarment(dir_, p);
  WriteFileAtomic(dir_ / "trace.json", R"({"placed": true, "placed_garment": "placed.json"})");
  for (const fs::path& path : {dir_, dir_ / "placed.json", dir_ / "trace.json"}) {
    EXPECT_TRUE(IsPlacedGarmentPath(path)) << path;
    const PlacedGarment r = ReadPlacedGarment(path);
    EXPECT_EQ(r.garment.category, "long_sleeve_shirt");
    EXPECT_EQ(r.garment.instance, p.garment.instance);
    ASSERT_EQ(r.garment.mesh.NumVertices(), p.garment.mesh.NumVertices());
    EXPECT_TRUE(r.garment.mesh.F == p.garment.mesh.F);
    // PLY stores float32.
    EXPECT_LT((r.garment.mesh.V - p.garment.mesh.V).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LT((r.lying - p.lying).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_EQ(r.garment.layer, p.garment.layer);
    EXPECT_EQ(r.garment.anchors.size(), p.garment.anchors.size());
    EXPECT_EQ(r.material, "tshirt");
    EXPECT_EQ(r.stiffness, 0.21);
    EXPECT_EQ(r.friction, 0.45);
  }
  EXPECT_FALSE(IsPlacedGarmentPath(dir_ / "lying.ply"));
}

TEST_F(PlacedFiles, ATrialThatDidNotPlaceItsGarmentOrAMissingMeshIsAnError) {
  fs::create_directories(dir_);
  WriteFileAtomic(dir_ / "trace.json", R"({"placed": false, "place_failure": "a gripper holds no cloth node"})");
  try {
    ReadPlacedGarment(dir_);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("did not place its garment flat"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("a gripper holds no cloth node"), std::string::npos) << e.what();
  }
  PlacedGarment p;
  p.garment = Shirt();
  p.lying = tabletop::LayFlat(p.garment.mesh, tabletop::TableOptions{});
  p.material = "tshirt";
  p.stiffness = 0.2;
  p.friction = 0.4;
  WritePlacedGarment(dir_, p);
  fs::remove(dir_ / "lying.ply");
  EXPECT_THROW(ReadPlacedGarment(dir_), Error);
}

}  // namespace
}  // namespace drape::folding
