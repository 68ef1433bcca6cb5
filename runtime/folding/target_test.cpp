// The ideal fold: mirror image across the line, turned over on top of the stack; the
// half-turn rotation agrees with it; the camera over the table sees a laid template
// with its key points where its anchors are.
#include "runtime/folding/target.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "garments/templates.h"
#include "runtime/folding/dissimilarity.h"
#include "runtime/folding/keypoints.h"
#include "runtime/tabletop/table.h"

namespace drape::folding {
namespace {

TEST(IdealFold, MirrorsTheGraspedSideOnTopOfTheStack) {
  Points3 cur(3, 3);
  cur << 0.3, 0.002, 0.1,  // folded side (x > 0.1)
      -0.2, 0.012, 0.0,    // other side, the highest point
      0.15, 0.012, -0.2;   // folded side
  const IdealFold fold(FoldLine{Vec2(0.1, 0), Vec2(0, 1)}, Vec2(0.5, 0), cur, 0.004);
  EXPECT_NEAR(fold.axis_height(), 0.014, 1e-15);
  EXPECT_TRUE(fold.Apply(cur.row(0).transpose()).isApprox(Vec3(-0.1, 0.026, 0.1)));
  EXPECT_TRUE(fold.Apply(cur.row(1).transpose()).isApprox(cur.row(1).transpose()));
  // The stack's top (0.012) lands one thickness above it.
  EXPECT_NEAR(fold.Apply(cur.row(2).transpose()).y(), 0.016, 1e-15);
  for (int i : {0, 2}) {
    const Vec3 p = cur.row(i).transpose();
    const Vec3 pivot(0.1, fold.axis_height(), p.z());
    EXPECT_TRUE((pivot + fold.Rotation(1) * (p - pivot)).isApprox(fold.Apply(p), 1e-12));
    // Half-way through, the folded part stands above the axis.
    EXPECT_GT((pivot + fold.Rotation(0.5) * (p - pivot)).y(), fold.axis_height());
  }
  EXPECT_THROW(IdealFold(FoldLine{Vec2(0.1, 0), Vec2(0, 1)}, Vec2(0.1, 0.3), cur, 0.004), Error);
  EXPECT_THROW(IdealFold(FoldLine{Vec2(0.1, 0), Vec2(0, 0)}, Vec2(0.5, 0.3), cur, 0.004), Error);
}

// A folded part thicker than the stack it lands on (the shirt's side flap carrying its
// folded sleeve) rests one thickness above that stack in the plan's ideal; IdealFold's
// rigid half-turn (a step's target) lifts it above its own top. On an even stack the
// two agree.
TEST(LandedFold, AThickFlapRestsOnTheStackItLandsOn) {
  Points3 cur(4, 3);
  cur << 0.3, 0.002, 0.0,  // the flap (x > 0.1): 0.002 to 0.030
      0.3, 0.030, 0.0,     //
      -0.1, 0.006, 0.0,    // the stack under its image (x = -0.1)
      -0.1, 0.002, 0.0;
  const Faces F(0, 3);
  const IdealFold fold(FoldLine{Vec2(0.1, 0), Vec2(0, 1)}, Vec2(0.5, 0), cur, 0.004, 0.01);
  const TriMesh landed = LandedFold(TriMesh{cur, F}, fold);
  EXPECT_NEAR(landed.V(1, 1), 0.010, 1e-15);  // its top, turned over, 4 mm above 0.006
  EXPECT_NEAR(landed.V(0, 1), 0.038, 1e-15);
  EXPECT_NEAR(landed.V(0, 0), -0.1, 1e-15);
  EXPECT_EQ(landed.V.row(2), cur.row(2));
  EXPECT_NEAR(fold.Apply(cur.row(1).transpose()).y(), 0.034, 1e-15);  // rigid: the axis at 0.030 + 0.002
  // Under nothing (reach 1 cm, the image 5 cm from the stack): on the table's level.
  const IdealFold far(FoldLine{Vec2(0.125, 0), Vec2(0, 1)}, Vec2(0.5, 0), cur, 0.004, 0.01);
  EXPECT_NEAR(LandedFold(TriMesh{cur, F}, far).V(1, 1), 0.002, 1e-15);
  // An even stack: the half-turn.
  Points3 even = cur;
  even(1, 1) = 0.006;
  const IdealFold e(FoldLine{Vec2(0.1, 0), Vec2(0, 1)}, Vec2(0.5, 0), even, 0.004, 0.01);
  const TriMesh le = LandedFold(TriMesh{even, F}, e);
  for (int i = 0; i < 4; ++i)
    EXPECT_TRUE(le.V.row(i).isApprox(e.Apply(even.row(i).transpose()).transpose(), 1e-12)) << i;
}

TEST(IdealFold, TargetOfATowelFoldedInHalfAndTheDissimilarityOfTheFlatTowel) {
  TemplateOptions o;
  o.edge_length = 0.04;
  const Garment towel = MakeGarment("towel", o);
  const TriMesh flat{tabletop::LayFlat(towel.mesh, tabletop::TableOptions{}), towel.mesh.F};
  const IdealFold fold(FoldLine{Vec2(0, 0), Vec2(1, 0)}, Vec2(0, 0.2), flat.V, 0.004);
  const TriMesh t = TargetShape(flat, fold);
  EXPECT_EQ(Dissimilarity(t, t), 0.0);
  // Half the cloth moved: its barycentres by twice their distance to the line (≈ a
  // quarter of the height on average), the other half not at all.
  const double h = flat.V.col(2).maxCoeff() - flat.V.col(2).minCoeff();
  const double d = Dissimilarity(t, flat);
  EXPECT_NEAR(d, 0.5 * 2 * h / 4, 0.1 * d);
  for (int i = 0; i < t.NumVertices(); ++i) EXPECT_LE(std::abs(t.V(i, 2)), h / 2 + 1e-9);
}

TEST(Camera, KeyPointsOfALaidTemplateAreWhereItsAnchorsAre) {
  TemplateOptions o;
  o.edge_length = 0.03;
  for (const std::string name : {"towel", "pants", "long_sleeve_shirt"}) {
    const Garment g = MakeGarment(name, o);
    const tabletop::TableOptions table;
    const Vec2 offset(0.05, -0.03);
    const TriMesh laid{tabletop::LayFlat(g.mesh, table, offset), g.mesh.F};
    const tabletop::TopDownCamera cam = tabletop::FrameCamera(laid.V, 0.003);
    const auto k = DetectKeyPoints(tabletop::TopDownMask(laid, cam), name);
    for (const Anchor& a : g.anchors) {
      if (!k.count(a.label) || a.label.find("shoulder") != std::string::npos) continue;
      const Vec2 w = cam.ToWorldXZ(k.at(a.label));
      Vec3 truth = laid.V.row(a.vertex).transpose();
      if (a.label == "collar") {
        // Seen from above the neck notch is the back neckline's (higher than the front's,
        // where the anchor is): its lowest point, a back vertex on the centre line.
        const auto& p = MakeTemplateShape(name, o).params;
        const Vec2 bottom(0, p.at("body_length") - p.at("neck_depth") + p.at("back_neck_rise"));
        int best = -1;
        for (int v = 0; v < g.mesh.NumVertices(); ++v)
          if (g.layer[v] == 1 &&
              (best < 0 || (Vec2(g.uv.row(v)) - bottom).norm() < (Vec2(g.uv.row(best)) - bottom).norm()))
            best = v;
        EXPECT_LT((Vec2(g.uv.row(best)) - bottom).norm(), 1e-12);
        truth = laid.V.row(best).transpose();
      }
      EXPECT_LT((w - Vec2(truth.x(), truth.z())).norm(), 0.025) << name << " " << a.label;
      const Vec2 back = cam.ToFrame(w.x(), w.y());
      EXPECT_LT((back - k.at(a.label)).norm(), 1e-9);
    }
  }
}

}  // namespace
}  // namespace drape::folding
