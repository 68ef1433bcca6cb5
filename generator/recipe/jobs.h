// Job expansion: a recipe becomes a deterministic list of jobs, one per garment
// instance × material × anchor (× perturbed repeat × hang of the anchor). Keys, ids, seeds and
// perturbations depend only on the recipe, never on thread count or shard.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/mesh.h"
#include "generator/hang/material.h"
#include "generator/recipe/recipe.h"

namespace drape {

struct Job {
  int index = 0;               // position in the expansion order (train, calibration, test)
  std::string key;             // stable unique key, e.g. "pants/i2/jeans/waist_left" ("/p1" added when repeats > 1)
  std::string id;              // entry folder name: zero-padded index + slug, e.g. "00007-pants-i2-jeans-waist_left"
  std::string split;           // "train" | "calibration" | "test"
  std::string sensing;         // key into Recipe::sensing
  int garment = 0;             // index into Recipe::garments
  int instance = 0;            // 0-based instance of that garment
  std::string instance_name;   // "<garment>/i<k>"
  uint64_t instance_seed = 0;  // TemplateOptions::seed of this instance (never 0)
  std::string material_name;   // the recipe's material name (before jitter)
  Material material;           // the values used (jittered on perturbed splits)
  std::string anchor;          // anchor label
  int repeat = 0;
  uint64_t seed = 0;  // DeriveSeed(recipe seed, key)
  // Seed of the hang: DeriveSeed(DeriveSeed(recipe seed, key without a ladder split's
  // "<split>/" prefix), "hang"), so a ladder rung hangs like the database entry.
  uint64_t hang_seed = 0;
  // Perturbations (zero / one when the split has none).
  double size_scale = 1.0;                   // uniform scale of the instance's mesh and pattern
  double material_jitter[4] = {0, 0, 0, 0};  // applied factors − 1: stretch, friction, density, bending
  Vec2 grasp_offset = Vec2::Zero();          // metres on the flat pattern
  double turn = 0;                           // radians about the gripper (y) axis, applied before the sweep
  double pose_noise_degrees = 0;             // the fusion's gripper encoder noise (σ per frame)
  // The anchor's hang k of SplitSpec::hangs_per_anchor (0: the anchor's own hang) and what
  // its hang variation drew (zero for hang 0); grasp_offset and material include them.
  int hang = 0;
  Vec2 hang_miss = Vec2::Zero();                  // m on the flat pattern, added to grasp_offset
  double hang_material_jitter[4] = {0, 0, 0, 0};  // applied factors − 1, on top of material_jitter
  Vec3 pickup_spin = Vec3::Zero();                // rad/s, the fall's start (HangStart::spin)
};

// Seed of garment instance k (its TemplateOptions::seed): DeriveSeed(recipe seed,
// "<garment>/i<k>"), never 0 (0 means preset proportions to MakeGarment).
uint64_t InstanceSeed(const Recipe& recipe, const std::string& garment, int instance);

// Every job of the recipe, in order: splits (train, calibration, test, the miss curve's,
// the ladder's), their garment selectors, instances ascending, the garment's materials,
// its anchors in label order, repeats, hangs.
std::vector<Job> ExpandJobs(const Recipe& recipe);

// Indices of the jobs of shard K of N (1 <= K <= N): index % N == K − 1.
std::vector<int> ShardJobs(int num_jobs, int k, int n);

// The garment of a job's instance: the template with the instance's seed (or the
// imported file), scaled by the job's size perturbation. Deterministic; the build caches
// it per instance and size, the runtime makes its test garments with it.
Garment MakeJobGarment(const Recipe& recipe, const Job& job);

// Hang options as used for a garment: the material fit is done at the garment's
// mesh resolution (its edge length), as hang.h recommends.
HangOptions HangOptionsFor(const Recipe& recipe, const GarmentSpec& garment);

// "pants/i2/jeans/waist_left" → "pants-i2-jeans-waist_left" (filesystem-safe).
std::string Slug(const std::string& key);

}  // namespace drape
