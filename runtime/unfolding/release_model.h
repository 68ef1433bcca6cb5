// What the unfolding loop knows of a release: its database, weights, recipe, database
// meshes (read on first use) and the test garments it unfolds.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "garments/garment.h"
#include "generator/hang/hang.h"
#include "generator/hang/material.h"
#include "generator/recipe/recipe.h"
#include "generator/release/release.h"
#include "generator/sweep/sweep.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/unfolding/objective.h"

namespace drape::unfolding {

class ReleaseModel {
 public:
  // Throws drape::Error if the release has no recipe or no usable train entry, or if
  // `weights_path` is given and cannot be read.
  ReleaseModel(const std::filesystem::path& release_dir, const std::filesystem::path& weights_path);
  ~ReleaseModel();

  const Release& release() const;
  const Recipe& recipe() const;
  const recognition::Database& database() const;
  const recognition::Weights* weights() const;  // null without weights
  const recognition::Recognizer& recognizer(bool weighted) const;
  // Database entry's hung mesh (object frame), cached.
  const TriMesh& HungMesh(int entry) const;
  // Anchors (label, uv) of a database garment instance, in label order.
  std::vector<AnchorPoint> InstanceAnchors(const std::string& instance) const;
  // Flat-pattern position (m) of `anchor` on database `instance`; none if unknown.
  std::optional<Vec2> AnchorUv(const std::string& instance, const std::string& anchor) const;
  // Vertex of `anchor` in the meshes of database `instance`'s entries; -1 if unknown.
  int AnchorVertex(const std::string& instance, const std::string& anchor) const;
  // The recipe's sensing for the test split: what the simulated Kinect is.
  SweepOptions TestSensing() const;
  // The category's test garment instances (from the recipe's test split): garment,
  // material and its cloth fit (the one the build recorded in the test entry's record,
  // else FitMaterial). Throws drape::Error if the category has none.
  struct TestGarment {
    Garment garment;
    Material material;
    MaterialFit fit;
    HangOptions hang;
    std::string instance;
  };
  std::vector<std::string> TestCategories() const;
  const TestGarment& TestInstance(const std::string& category) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace drape::unfolding
