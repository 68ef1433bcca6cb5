// Time of one unfolding trial split into simulation (cloth hangs), sensing (Kinect
// sweeps), fusion (+ feature), recognition, registration and refinement (IR scan).
//
//   unfold_bench RELEASE [CATEGORY] [FRAMES] [SEED]
//
// RELEASE needs weights from `drape calibrate`. Defaults: the release's first test
// category with a desired pair, 550 frames (the paper's), seed 1. Prints figures only.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>

#include "runtime/recognition/release_source.h"
#include "runtime/unfolding/loop.h"

int main(int argc, char** argv) {
  using namespace drape::unfolding;
  if (argc < 2) {
    std::fprintf(stderr, "usage: unfold_bench RELEASE [CATEGORY] [FRAMES] [SEED]\n");
    return 2;
  }
  try {
    const std::filesystem::path dir = argv[1];
    const drape::Release probe = drape::Release::Open(dir);
    const ReleaseModel model(dir, drape::recognition::DefaultWeightsDir(probe) / "weights.json");
    std::string category = argc > 2 ? argv[2] : "";
    if (category.empty())
      for (const std::string& c : model.TestCategories())
        if (category.empty() && !DesiredPairsFor(c).empty()) category = c;
    LoopOptions o;
    o.observe.capture.frames = argc > 3 ? std::atoi(argv[3]) : 550;
    const uint64_t seed = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 1;
    model.TestInstance(category);  // material fit outside the timing
    const TrialResult t = RunTrial(model, category, o, seed);
    const StageTimes& s = t.times;
    const double staged = s.simulation + s.sensing + s.fusion + s.recognition + s.registration + s.refinement;
    std::printf("unfold trial: %s, %d regrasps, %d sense/plan steps, %s, %d frames per turn\n", category.c_str(),
                t.regrasps, int(t.steps.size()), t.unfolded ? "unfolded" : "not unfolded", o.observe.capture.frames);
    auto row = [&](const char* name, double v) {
      std::printf("  %-13s %8.2f s  %5.1f %%\n", name, v, 100 * v / t.seconds);
    };
    row("simulation", s.simulation);
    row("sensing", s.sensing);
    row("fusion", s.fusion);
    row("recognition", s.recognition);
    row("registration", s.registration);
    row("refinement", s.refinement);
    row("other", t.seconds - staged);
    std::printf("  %-13s %8.2f s\n", "total", t.seconds);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "unfold_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
