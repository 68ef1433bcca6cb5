// On a real release (the quickstart, built by the e2e.quickstart_reference fixture):
// every hung mesh is free of self-intersections by CGAL's exact test (re-run here on
// the published hang.ply), and its edge strain is within the bounds (max ≤ 3×, p99 ≤
// 2× its material's stretch); no entry failed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "garments/io.h"
#include "generator/cloth/measure.h"
#include "generator/release/release.h"

namespace drape {
namespace {

TEST(HangQuality, EveryHungMeshOfTheQuickstartIsIntersectionFreeAndStrainBounded) {
  const char* dir = std::getenv("DRAPE_QUICKSTART_RELEASE");
  ASSERT_NE(dir, nullptr) << "run through ctest: the quickstart fixture sets DRAPE_QUICKSTART_RELEASE";
  const Release release = Release::Open(dir);
  ASSERT_FALSE(release.entries().empty());
  double worst_max = 0, worst_p99 = 0;
  for (const auto& e : release.entries()) {
    EXPECT_FALSE(e.failed) << e.id << ": " << e.failure;
    if (e.failed) continue;
    const TriMesh hung = ReadMesh(std::filesystem::path(dir) / "entries" / e.id / "hang.ply");
    EXPECT_EQ(SelfIntersectingFacePairs(hung).size(), 0u) << e.id;
    const Json& h = e.record.at("hang");
    EXPECT_EQ(h.at("intersecting_pairs").get<int>(), 0) << e.id;
    EXPECT_GT(h.at("min_distance").get<double>(), 0) << e.id;
    const double stretch = e.record.at("material_values").at("stretch_percent").get<double>() / 100;
    const double mx = h.at("strain_max").get<double>() / stretch, p99 = h.at("strain_p99").get<double>() / stretch;
    EXPECT_LE(mx, 3.0) << e.id;
    EXPECT_LE(p99, 2.0) << e.id;
    worst_max = std::max(worst_max, mx);
    worst_p99 = std::max(worst_p99, p99);
  }
  std::cout << release.entries().size() << " entries: worst edge strain max " << worst_max << " × stretch, p99 "
            << worst_p99 << " × stretch\n";
}

}  // namespace
}  // namespace drape
