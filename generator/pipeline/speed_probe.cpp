// The machine's speed probe (cost.h): a fixed cloth simulation, timed.
#include <algorithm>
#include <limits>

#include "common/cpu_time.h"
#include "generator/cloth/rectangle.h"
#include "generator/cloth/world.h"
#include "generator/pipeline/cost.h"

namespace drape {

double SpeedProbeCpuSeconds() {
  // What builds spend most on (the hang: Bullet's step, hinge bending, self-collision),
  // at a size that takes ~50 ms: a two-layer 25 × 35 cm sheet of 3.5 cm edges (176
  // nodes) with hinge bending, held at a corner and left to fall for 1 s (240 steps).
  const Garment g = MakeRectangleGarment(0.25, 0.35, 0.035, true);
  ClothMaterial material;
  material.area_density = 0.2;
  material.link_stiffness = 0.5;
  material.bending_rigidity = 2e-5;
  material.bending_scale = 3;
  material.max_strain = 0.05;
  const auto model = MakeClothModel(g.mesh, g.layer, material, ClothOptions{});
  // The least of five runs after one not counted (a busy core, a clock still ramping up
  // and a cold cache only slow a run).
  double best = std::numeric_limits<double>::infinity();
  for (int run = 0; run < 6; ++run) {
    const double c0 = ThreadCpuSeconds();
    ClothWorld world(model, g.mesh.V);
    const int corner = g.anchors[0].vertex;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = g.mesh.V.row(corner).transpose();
    world.Hold(world.AddGripper(Jaw{}, pose), {corner});
    for (int step = 0; step < 240; ++step) world.Step();
    if (run > 0) best = std::min(best, ThreadCpuSeconds() - c0);
  }
  return best;
}

}  // namespace drape
