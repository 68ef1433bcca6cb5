// The table and the camera above it: a pattern laid flat, a garment lying elsewhere moved
// back upright, and the top-down mask's area.
#include "runtime/tabletop/table.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"
#include "garments/templates.h"

namespace drape::tabletop {
namespace {

Garment Shirt() {
  TemplateOptions o;
  o.edge_length = 0.05;
  return MakeGarment("long_sleeve_shirt", o);
}

TEST(PlaceOnTable, TurnsALaidPatternBackUprightOntoTheTable) {
  const Garment g = Shirt();
  TableOptions high;
  high.top = 0.75;
  const TableOptions table;
  const Points3 upright = LayFlat(g.mesh, table);
  for (double yaw : {0.0, 0.4, 2.5, M_PI, -1.2}) {
    // On another table, elsewhere, turned: back to what LayFlat gives on this one.
    const Points3 lying = LayFlat(g.mesh, high, Vec2(0.3, -0.2), yaw);
    EXPECT_LT((PlaceOnTable(lying, g.mesh, table) - upright).cwiseAbs().maxCoeff(), 1e-9) << yaw;
    EXPECT_LT(
        (PlaceOnTable(lying, g.mesh, table, Vec2(0.02, 0.01), 0.07) - LayFlat(g.mesh, table, Vec2(0.02, 0.01), 0.07))
            .cwiseAbs()
            .maxCoeff(),
        1e-9)
        << yaw;
  }
  EXPECT_THROW(PlaceOnTable(upright.topRows(10), g.mesh, table), Error);
}

TEST(PlaceOnTable, KeepsTheShapeOfACrumpledGarment) {
  const Garment g = Shirt();
  Points3 lying = LayFlat(g.mesh, TableOptions{}, Vec2::Zero(), 0.8);
  for (int i = 0; i < lying.rows(); ++i) lying(i, 1) += 0.05 * std::sin(7 * lying(i, 0)) + 0.05;
  const Points3 placed = PlaceOnTable(lying, g.mesh, TableOptions{});
  EXPECT_NEAR(placed.col(1).minCoeff(), TableOptions{}.clearance, 1e-12);
  // A rigid motion: every distance to vertex 0 kept.
  for (int i = 0; i < lying.rows(); ++i)
    EXPECT_NEAR((placed.row(i) - placed.row(0)).norm(), (lying.row(i) - lying.row(0)).norm(), 1e-9);
}

// A 0.4 × 0.3 m rectangle laid flat covers its area in the mask, at any yaw, to within
// the pixels its outline cuts (1 mm pixels: a ±1.4 mm band around a 1.4 m outline).
TEST(TopDownMask, ALaidRectangleCoversItsArea) {
  TriMesh rect;
  rect.V.resize(4, 3);
  rect.V << -0.2, -0.15, 0, 0.2, -0.15, 0, 0.2, 0.15, 0, -0.2, 0.15, 0;
  rect.F.resize(2, 3);
  rect.F << 0, 1, 2, 0, 2, 3;
  for (double yaw : {0.0, 0.3, 1.2}) {
    const TriMesh laid{LayFlat(rect, TableOptions{}, Vec2(0.1, -0.05), yaw), rect.F};
    EXPECT_NEAR(laid.V.col(1).minCoeff(), TableOptions{}.clearance, 1e-12);
    const TopDownCamera cam = FrameCamera(laid.V, 0.001);
    const double area = cv::countNonZero(TopDownMask(laid, cam)) * 1e-6;
    EXPECT_NEAR(area, 0.12, 0.002) << yaw;
    // The camera frames the garment with its margin, and a pixel's centre maps back.
    const Vec2 c = cam.ToWorldXZ(cam.ToFrame(0.1, -0.05));
    EXPECT_NEAR(c.x(), 0.1, 1e-9);
    EXPECT_NEAR(c.y(), -0.05, 1e-9);
  }
  EXPECT_THROW(FrameCamera(rect.V, 0), Error);
}

}  // namespace
}  // namespace drape::tabletop
