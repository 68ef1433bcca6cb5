// The twin discriminator by the cue's fit (twin_fit.h): twins that differ only by a local
// bump, which the whole-shape residual cannot tell apart; the rule and its errors.
#include "runtime/recognition/twin_fit.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/closest_point.h"
#include "common/error.h"
#include "runtime/recognition/test_features.h"
#include "runtime/registration/test_meshes.h"

namespace drape::recognition {
namespace {

namespace rt = drape::registration::testing;

// `m` with a bump of `amp` m (a Gaussian of σ 4 cm) on its front face (z > 0) around
// (x, y) = `at`.
TriMesh Bumped(TriMesh m, const Vec2& at, double amp) {
  for (int v = 0; v < m.NumVertices(); ++v) {
    if (m.V(v, 2) <= 0) continue;
    const double d2 = (m.V.row(v).head<2>().transpose() - at).squaredNorm();
    m.V(v, 2) += amp * std::exp(-d2 / (2 * 0.04 * 0.04));
  }
  return m;
}

int NearestVertex(const TriMesh& m, const Vec3& p) {
  int best = 0;
  for (int v = 1; v < m.NumVertices(); ++v) {
    if ((m.V.row(v).transpose() - p).squaredNorm() < (m.V.row(best).transpose() - p).squaredNorm()) best = v;
  }
  return best;
}

// Two twins of one garment instance: `right_cuff` has the cue (a bump by the collar, on
// the front near the top), `left_cuff` the same bump far from it (near the bottom). The
// query's reconstruction has both bumps: each twin misses one bump of the same size, so
// the whole shapes fit equally badly; near the cue only `right_cuff` fits. The bits
// match `left_cuff` (10 bits against 20).
struct Twins {
  TriMesh base = rt::FlatTube(32, 28, 0.35, 0.8, 0.06);
  Vec2 cue{0.0, -0.12}, far{0.0, -0.62};
  TriMesh with_cue = Bumped(base, cue, 0.03), far_bump = Bumped(base, far, 0.03);
  TriMesh recon = Bumped(Bumped(base, cue, 0.03), far, 0.03);
  int cue_vertex = NearestVertex(base, Vec3(cue.x(), cue.y(), 0.03));
  Database db;
  std::vector<Match> matches;
  Twins() {
    Rng rng(11);
    const Code q = RandomCode(rng, 8, 8, 16);
    std::vector<LabelledCode> e;
    e.push_back(Labelled("l", "long_sleeve_shirt", "shirt/i0", "left_cuff", FlipBits(q, rng, 10)));
    e.push_back(Labelled("r", "long_sleeve_shirt", "shirt/i0", "right_cuff", FlipBits(q, rng, 20)));
    e.push_back(Labelled("c", "long_sleeve_shirt", "shirt/i0", "collar", RandomCode(rng, 8, 8, 16)));
    e[2].label.anchor_vertex = cue_vertex;
    db = Database(std::move(e));
    db.matcher().MatchAll(PreparedQuery(q), &matches);
  }
  std::function<TriMesh(int)> Hung() const {
    return [this](int entry) { return entry == 1 ? with_cue : entry == 0 ? far_bump : base; };
  }
};

TEST(TwinFit, TheCueTellsTwinsApartThatTheWholeShapeCannot) {
  const Twins t;
  ASSERT_EQ(t.matches[0].rotation, 0);
  ASSERT_EQ(t.matches[1].rotation, 0);
  ASSERT_LT(t.matches[0].distance, t.matches[1].distance);  // the bits pick left_cuff
  TwinFitOptions o;
  o.radius = 0.08;
  o.direction = TwinDirection::kBoth;
  o.margin = 0;
  TwinFit fit = TwinByFit(t.db, t.matches, 0, {}, t.recon, t.Hung(), o);
  EXPECT_EQ(fit.matched_anchor, "left_cuff");
  EXPECT_EQ(fit.twin_anchor, "right_cuff");
  ASSERT_EQ(fit.sides.size(), 2u);
  EXPECT_TRUE(fit.switched);
  EXPECT_EQ(fit.anchor, "right_cuff");
  EXPECT_EQ(fit.entry, 1);
  EXPECT_LT(fit.twin_residual, 0.5 * fit.matched_residual);
  // Each direction alone tells them apart too.
  for (TwinDirection d : {TwinDirection::kDbToRecon, TwinDirection::kReconToDb}) {
    o.direction = d;
    DecideTwin(fit, o);
    EXPECT_EQ(fit.anchor, "right_cuff") << TwinDirectionName(d);
    EXPECT_LT(fit.twin_residual, 0.5 * fit.matched_residual) << TwinDirectionName(d);
  }
  // Signed along the reconstruction's normals: the twin lies on it near the cue; the
  // matched mesh lacks the query's bump and lies off it, on the same side by both
  // definitions (this tube's faces wind inwards, so the sign itself says nothing here).
  const CueResidual& m = fit.sides[0].cue[0];
  const CueResidual& w = fit.sides[1].cue[0];
  EXPECT_LT(std::abs(w.db_signed), 1e-3);
  EXPECT_LT(std::abs(w.recon_signed), 1e-3);
  EXPECT_GT(std::abs(m.db_signed), 5e-3);
  EXPECT_GT(m.db_signed * m.recon_signed, 0);
  // The whole shapes: a tie within a few per cent.
  const double a = fit.sides[0].whole_fit, b = fit.sides[1].whole_fit;
  ASSERT_GT(a, 0);
  EXPECT_NEAR(a / b, 1.0, 0.1);
  // A margin above the cue's gap keeps the bits' answer.
  o.direction = TwinDirection::kBoth;
  o.margin = 0.99;
  DecideTwin(fit, o);
  EXPECT_FALSE(fit.switched);
  EXPECT_EQ(fit.anchor, "left_cuff");
  EXPECT_EQ(fit.entry, 0);
}

TEST(TwinFit, ApplyMakesTheTwinTheAnswer) {
  const Twins t;
  const Recognizer rec(t.db, nullptr);
  RecognizeOptions ro;
  ro.category = "long_sleeve_shirt";
  std::vector<Match> m = t.matches;
  Rng rng(11);
  Recognition r = rec.Rank(PreparedQuery(RandomCode(rng, 8, 8, 16)), m, ro);
  ASSERT_EQ(r.anchor, "left_cuff");
  TwinFitOptions o;
  o.radius = 0.08;
  o.direction = TwinDirection::kBoth;
  const TwinFit fit = TwinByFit(t.db, t.matches, r.best.entry, {}, t.recon, t.Hung(), o);
  ApplyTwinFit(t.db, t.matches, fit, r);
  EXPECT_EQ(r.anchor, "right_cuff");
  EXPECT_EQ(r.best.entry, 1);
  EXPECT_EQ(r.best.distance, t.matches[1].distance);
  ASSERT_FALSE(r.top.empty());
  EXPECT_EQ(r.top[0].anchor, "right_cuff");
  const Json j = ToJson(fit);
  EXPECT_TRUE(j["switched"].get<bool>());
  EXPECT_EQ(j["sides"].size(), 2u);
}

TEST(TwinFit, AnAnchorWithoutATwinKeepsTheMatch) {
  const Twins t;
  const TwinFit fit = TwinByFit(t.db, t.matches, 2, {}, TriMesh{}, t.Hung(), TwinFitOptions{});
  EXPECT_TRUE(fit.twin_anchor.empty());
  EXPECT_TRUE(fit.sides.empty());
  EXPECT_FALSE(fit.switched);
  EXPECT_EQ(fit.anchor, "collar");
  EXPECT_EQ(TwinInDatabase(t.db, 0), "right_cuff");
  EXPECT_EQ(TwinInDatabase(t.db, 2), "");
}

TEST(TwinFit, AFailedRegistrationKeepsTheMatch) {
  const Twins t;
  auto broken = [&](int entry) -> TriMesh {
    if (entry == 1) throw Error("hang.ply unreadable");
    return t.far_bump;
  };
  const TwinFit fit = TwinByFit(t.db, t.matches, 0, {}, t.recon, broken, TwinFitOptions{});
  ASSERT_EQ(fit.sides.size(), 2u);
  EXPECT_EQ(fit.sides[1].failure, "hang.ply unreadable");
  EXPECT_FALSE(fit.switched);
  EXPECT_EQ(fit.anchor, "left_cuff");
  EXPECT_FALSE(fit.compared);
}

TEST(TwinFit, CueAnchorsAreTheNecklineElseTheWaist) {
  EXPECT_EQ(CueAnchors({"collar", "left_cuff", "left_neck", "left_waist", "right_neck"}),
            (std::vector<std::string>{"collar", "left_neck", "right_neck"}));
  EXPECT_EQ(CueAnchors({"crotch", "left_waist", "right_waist", "waist_center", "left_knee"}),
            (std::vector<std::string>{"left_waist", "right_waist", "waist_center"}));
  EXPECT_TRUE(CueAnchors({"top_left", "top_right"}).empty());
  EXPECT_TRUE(CueAnchors({"necklace_x"}).empty());  // whole tokens only
}

TEST(TwinFit, MeasureCueIsLocal) {
  const Twins t;
  const ExactClosestPoint onto(t.recon);
  const CueResidual with = MeasureCue(t.with_cue, {t.cue_vertex}, t.recon, onto, 0.08);
  const CueResidual without = MeasureCue(t.far_bump, {t.cue_vertex}, t.recon, onto, 0.08);
  EXPECT_GT(with.db_samples, 0);
  EXPECT_GT(with.recon_samples, 0);
  EXPECT_LT(with.db_to_recon, 1e-6);
  EXPECT_GT(without.db_to_recon, 0.003);
  // No cue vertex: nothing measured.
  const CueResidual none = MeasureCue(t.with_cue, {}, t.recon, onto, 0.08);
  EXPECT_LT(none.db_to_recon, 0);
  EXPECT_EQ(none.db_samples, 0);
}

TEST(TwinFit, BadOptionsAreClearErrors) {
  auto message = [](const TwinFitOptions& o) {
    try {
      o.Validate();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  TwinFitOptions o;
  o.radius = 0;
  EXPECT_NE(message(o).find("radius"), std::string::npos);
  o.radius = std::nan("");
  EXPECT_NE(message(o).find("radius"), std::string::npos);
  o = {};
  o.instances = 2;
  EXPECT_NE(message(o).find("instances"), std::string::npos);
  o = {};
  o.margin = 1;
  EXPECT_NE(message(o).find("margin"), std::string::npos);
  o.margin = -0.1;
  EXPECT_NE(message(o).find("margin"), std::string::npos);
  EXPECT_EQ(message(TwinFitOptions{}), "");
  EXPECT_THROW(ParseTwinDirection("sideways"), Error);
  for (TwinDirection d :
       {TwinDirection::kDbToRecon, TwinDirection::kReconToDb, TwinDirection::kBoth, TwinDirection::kWhole})
    EXPECT_EQ(ParseTwinDirection(TwinDirectionName(d)), d);
  const Twins t;
  o = {};
  o.radius = -1;
  EXPECT_THROW(TwinByFit(t.db, t.matches, 0, {}, t.recon, t.Hung(), o), Error);
  EXPECT_THROW(TwinByFit(t.db, t.matches, 7, {}, t.recon, t.Hung(), TwinFitOptions{}), Error);
  EXPECT_THROW(TwinByFit(t.db, t.matches, 0, {}, t.recon, t.Hung(), TwinFitOptions{}, {0.0}), Error);
}

}  // namespace
}  // namespace drape::recognition
