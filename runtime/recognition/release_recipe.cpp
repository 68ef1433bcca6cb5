#include "runtime/recognition/release_recipe.h"

#include <sstream>

namespace drape::recognition {

std::string DescribeSplit(const SplitSpec& s) {
  std::ostringstream d;
  d << (s.sensing == "database" ? "no noise" : "Kinect noise");
  const Perturbation& p = s.perturbation;
  if (p.turn) d << ", turned";
  if (s.miss_level >= 0)
    d << ", grasp " << s.miss_level * 1000 << " mm from the anchor (miss curve)";
  else if (p.grasp_offset > 0)
    d << ", grasp offset " << p.grasp_offset * 100 << " cm";
  if (p.grasp_miss > 0) d << ", grasp miss σ " << p.grasp_miss * 1000 << " mm per axis";
  if (p.gripper_pose_noise > 0) d << ", gripper noise " << p.gripper_pose_noise << "°";
  if (p.size_scale_min != 1 || p.size_scale_max != 1)
    d << ", size ×[" << p.size_scale_min << ", " << p.size_scale_max << "]";
  if (p.material_jitter > 0) d << ", material jitter " << p.material_jitter * 100 << " %";
  return d.str();
}

std::optional<Recipe> ReleaseRecipe(const Release& release) {
  const std::string text = release.dataset().value("recipe", Json::object()).value("text", "");
  if (text.empty()) return std::nullopt;
  return ParseRecipe(text, (release.dir() / "dataset.json").string() + " (recipe)", release.dir());
}

}  // namespace drape::recognition
