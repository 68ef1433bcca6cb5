// The pick-up phase (trial.h): the garment lies flat on the table and one gripper takes
// it at a seeded random point of its front layer, then carries it to the sensing pose.
#include "common/error.h"
#include "common/rng.h"
#include "runtime/unfolding/trial.h"

namespace drape::unfolding {

namespace hw = drape::hardware;

hw::GripperPose SensingPose(double height) {
  hw::GripperPose p;
  p.position = Vec3(0, height, 0);
  return p;
}

hw::GripperPose Home(int arm) {
  hw::GripperPose p;
  p.position = Vec3(arm == 0 ? 0.45 : -0.45, 1.3, 0.35);
  return p;
}

void Trial::PickUp() {
  const Garment& g = world_.garment();
  std::vector<int> front;
  for (int i = 0; i < g.mesh.NumVertices(); ++i)
    if (g.layer.empty() || g.layer[i] == 0) front.push_back(i);
  Rng rng(DeriveSeed(seed_, "first_grasp"));
  hw::Arm& a = world_.arm(0);
  for (int attempt = 0; attempt < 5; ++attempt) {
    const int v = front[rng.Below(front.size())];
    hw::GripperPose p;
    p.position = world_.mesh().V.row(v).transpose();
    a.Move(hw::StraightPath(a.pose(), p));
    if (a.Close().outcome != hw::GraspOutcome::kMiss) break;
    a.Open();
  }
  if (!a.HoldsCloth()) throw Error("first grasp: five attempts missed the garment");
  res_.first_grasp_uv = *world_.HeldUv(0);
  a.Move(hw::StraightPath(a.pose(), SensingPose(o_.observe.sensing_height)));
  holder_ = 0;
}

}  // namespace drape::unfolding
