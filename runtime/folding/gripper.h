// The gripper models a fold step can use (fold.h simulates them; a plan step may name
// one, plan.h). Apart from fold.h so that plans need not include the cloth world.
#pragma once

#include <string>

#include "common/error.h"

namespace drape::folding {

//   kPinch — a parallel-jaw gripper closing vertically through the cloth: it holds every
//            node of every layer in a small area;
//   kPoint — holds the single nearest top-layer vertex (the paper's simulation).
enum class GripperModel { kPinch, kPoint };

inline std::string GripperModelName(GripperModel m) { return m == GripperModel::kPinch ? "pinch" : "point"; }

// "pinch" | "point"; throws drape::Error otherwise.
inline GripperModel ParseGripperModel(const std::string& name) {
  if (name == "pinch") return GripperModel::kPinch;
  if (name == "point") return GripperModel::kPoint;
  throw Error("gripper model '" + name + "': expected pinch or point");
}

}  // namespace drape::folding
