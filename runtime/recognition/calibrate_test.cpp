#include "runtime/recognition/calibrate.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "common/error.h"
#include "common/files.h"
#include "common/rng.h"

namespace drape::recognition {
namespace {

namespace fs = std::filesystem;

Code RandomCode(Rng& rng, int l, int r, int s) {
  Code c = ZeroFeature(l, r, s);
  for (int b = 0; b < c.NumBits(); ++b) c.Set(b, rng.Uniform() < 0.5);
  return c;
}

// A synthetic category in which the lower half of the layers carries only noise: each
// anchor has a prototype that differs from a shared base in 24 bits of the upper
// (informative) layers; every sample keeps the prototype's informative bits up to a
// few flips and draws the noise layers afresh. The unweighted distance sums ~1024
// noise bit differences (σ ≈ 23 bits) on top of the ~80-bit anchor signal, so it errs;
// a w that ignores the noise layers should not.
struct NoisyCategory {
  static constexpr int kL = 16, kR = 16, kS = 16, kAnchors = 8;
  Code base;
  std::vector<Code> protos;
  explicit NoisyCategory(Rng& rng) {
    base = RandomCode(rng, kL, kR, kS);
    for (int a = 0; a < kAnchors; ++a) {
      Code p = base;
      for (int i = 0; i < 24; ++i) {
        const int b = static_cast<int>(rng.Below(uint64_t{kL / 2} * kR * kS));  // upper layers only
        p.Set(b, !p.Get(b));
      }
      protos.push_back(p);
    }
  }
  Code Sample(Rng& rng, int a, int flips) const {
    Code c = protos[a];
    for (int b = kL / 2 * kR * kS; b < c.NumBits(); ++b) c.Set(b, rng.Uniform() < 0.5);
    for (int i = 0; i < flips; ++i) {
      const int b = static_cast<int>(rng.Below(uint64_t{kL / 2} * kR * kS));
      c.Set(b, !c.Get(b));
    }
    return c;
  }
};

LabelledCode Labelled(const std::string& id, const std::string& anchor, const std::string& inst, Code c) {
  LabelledCode lc;
  lc.label.id = id;
  lc.label.category = "shirt";
  lc.label.instance = inst;
  lc.label.anchor = anchor;
  lc.code = std::move(c);
  return lc;
}

TEST(RecognitionCalibrate, LearnedWeightsIgnoreNoiseBitsAndCutTheError) {
  Rng rng(DeriveSeed(42, "noisy-category"));
  NoisyCategory cat(rng);
  std::vector<LabelledCode> train, calib, test;
  for (int a = 0; a < NoisyCategory::kAnchors; ++a) {
    const std::string an = "anchor" + std::to_string(a);
    for (int inst = 1; inst <= 2; ++inst) {
      train.push_back(
          Labelled("t" + an + std::to_string(inst), an, "shirt-" + std::to_string(inst), cat.Sample(rng, a, 4)));
    }
    for (int j = 0; j < 10; ++j) {
      calib.push_back(Labelled("c" + an + std::to_string(j), an, "shirt-c", cat.Sample(rng, a, 8)));
      // Test queries are also turned on the gripper by a random k·2π/Φ.
      test.push_back(Labelled("q" + an + std::to_string(j), an, "shirt-q",
                              Rotate(cat.Sample(rng, a, 8), static_cast<int>(rng.Below(16)))));
    }
  }
  Database db(train);
  CalibrateOptions opt;
  const CalibrationResult res = Calibrate(db, calib, opt, "digest-A");
  ASSERT_EQ(res.weights.per_category.count("shirt"), 1u);
  ASSERT_EQ(res.categories.size(), 1u);
  const CategoryCalibration& st = res.categories[0];
  EXPECT_EQ(st.queries, 80);
  EXPECT_EQ(st.pairs, 80LL * 2 * 14);
  EXPECT_GT(st.accuracy_after, st.accuracy_before);

  // Per bit, the bits that tell anchors apart (where some prototype differs from the
  // base) weigh far more than the pure-noise layers.
  const auto& w = res.weights.per_category.at("shirt");
  const int half = NoisyCategory::kL / 2 * NoisyCategory::kR * NoisyCategory::kS;
  double signal = 0, noise = 0;
  int n_signal = 0;
  for (int b = 0; b < half; ++b) {
    bool differs = false;
    for (const Code& p : cat.protos) differs |= p.Get(b) != cat.base.Get(b);
    if (differs) signal += w[b], ++n_signal;
  }
  for (int b = half; b < 2 * half; ++b) noise += w[b];
  const double ratio = (signal / n_signal) / (noise / half);
  EXPECT_GT(ratio, 5.0) << "mean weight on " << n_signal << " signal bits / mean weight on noise bits";

  Recognizer unweighted(db, nullptr), learned(db, &res.weights);
  int err_u = 0, err_w = 0;
  RecognizeOptions ro;
  for (const auto& q : test) {
    err_u += unweighted.Recognize(q.code, ro).anchor != q.label.anchor;
    const Recognition r = learned.Recognize(q.code, ro);
    EXPECT_TRUE(r.weighted);
    err_w += r.anchor != q.label.anchor;
  }
  // Measured when written (seed 42, database-frame w, C = 10): unweighted 11/80 wrong,
  // learned 0/80 wrong; calibration pair accuracy 0.917 -> 1.000; signal/noise weight 21.6.
  std::printf(
      "noisy-bits case: unweighted %d/80 wrong, learned %d/80 wrong; pair accuracy %.3f -> %.3f; "
      "signal/noise mean weight %.1f\n",
      err_u, err_w, st.accuracy_before, st.accuracy_after, ratio);
  EXPECT_GE(err_u, 6);
  EXPECT_LE(err_w * 3, err_u);
}

TEST(RecognitionCalibrate, SkipsUnusableQueriesAndAbsentCategories) {
  Rng rng(5);
  NoisyCategory cat(rng);
  std::vector<LabelledCode> train, calib;
  for (int a = 0; a < 3; ++a) {
    train.push_back(Labelled("t" + std::to_string(a), "a" + std::to_string(a), "i1", cat.Sample(rng, a, 4)));
    calib.push_back(Labelled("c" + std::to_string(a), "a" + std::to_string(a), "ic", cat.Sample(rng, a, 4)));
  }
  calib.push_back(Labelled("c-missing", "not_in_db", "ic", cat.Sample(rng, 0, 8)));
  LabelledCode other = Labelled("c-towel", "corner", "towel-1", cat.Sample(rng, 0, 8));
  other.label.category = "towel";
  calib.push_back(other);
  const CalibrationResult res = Calibrate(Database(train), calib, {}, "d");
  ASSERT_EQ(res.categories.size(), 1u);
  EXPECT_EQ(res.categories[0].queries, 3);
  EXPECT_EQ(res.categories[0].skipped, 1);
  EXPECT_EQ(res.weights.per_category.count("towel"), 0u);
  // The skipped query, the absent category, and: these synthetic entries have no height.
  ASSERT_EQ(res.warnings.size(), 3u);
  EXPECT_NE(res.warnings[2].find("no query has a known height"), std::string::npos) << res.warnings[2];
  EXPECT_EQ(res.weights.height_gates, (HeightGates{0, 0}));
  EXPECT_THROW(Calibrate(Database(), calib, {}, "d"), Error);
  EXPECT_THROW(Calibrate(Database(train), {}, {}, "d"), Error);
}

// The database itself as calibration queries (`drape calibrate --split train`): each
// entry ranks only the entries of the OTHER instances, never itself (distance 0).
TEST(RecognitionCalibrate, DatabaseEntriesAsQueriesRankOnlyOtherInstances) {
  Rng rng(7);
  NoisyCategory cat(rng);
  std::vector<LabelledCode> train;
  for (int a = 0; a < 3; ++a)
    for (int inst = 1; inst <= 3; ++inst)
      train.push_back(Labelled("t" + std::to_string(a) + std::to_string(inst), "a" + std::to_string(a),
                               "shirt-" + std::to_string(inst), cat.Sample(rng, a, 4)));
  const CalibrationResult res = Calibrate(Database(train), train, {}, "d");
  ASSERT_EQ(res.categories.size(), 1u);
  EXPECT_EQ(res.categories[0].queries, 9);
  // Per query: 6 entries of the two other instances, 2 relevant (its anchor) × 4 not.
  EXPECT_EQ(res.categories[0].pairs, 9LL * 2 * 4);
  // A single instance has nothing to rank against: every query is skipped.
  std::vector<LabelledCode> one(train.begin(), train.begin() + 1);
  one.push_back(train[3]);  // a1 of the same instance shirt-1
  one[1].label.instance = one[0].label.instance;
  const CalibrationResult none = Calibrate(Database(one), one, {}, "d");
  EXPECT_EQ(none.categories.at(0).queries, 0);
  EXPECT_EQ(none.categories.at(0).skipped, 2);
}

// --- The uniform prior (w = 1 + δ, ½‖δ‖²), weight tying, cross-validation ---

// A code whose every (layer, ring) annulus is all ones or all zeros: every rotation of it
// is itself, so the Eq. match rotation cannot change an XOR vector.
Code AnnulusCode(int l, int r, int s, const std::vector<int>& ones) {
  Code c = ZeroFeature(l, r, s);
  for (int a : ones)
    for (int k = 0; k < s; ++k) c.Set(a * s + k, true);
  return c;
}

// One query, one relevant entry 8 bits away (layer 1), one nonrelevant entry 4 bits away
// (layer 0): the unweighted distance orders the pair wrong by 4 bits. With one weight per
// layer, a = z_n − z_r = (4, −8), and min ½‖v − 1‖² + C·max(0, 1 − v·a) has the closed
// form v = 1 + t·a, t = min(C, (1 − 1·a)/‖a‖²) = min(C, 5/80).
TEST(RecognitionCalibrate, UniformPriorMatchesTheClosedFormOnOnePair) {
  const int L = 2, R = 2, S = 4;
  std::vector<LabelledCode> db_entries = {
      Labelled("rel", "A", "db", AnnulusCode(L, R, S, {2, 3})),  // layer 1, both rings
      Labelled("non", "B", "db", AnnulusCode(L, R, S, {0})),     // layer 0, ring 0
  };
  const std::vector<LabelledCode> q = {Labelled("q", "A", "cal", AnnulusCode(L, R, S, {}))};
  const Database db(db_entries);
  for (double c : {0.01, 0.03, 1.0, 100.0}) {
    CalibrateOptions opt;
    opt.regularizer = Regularizer::kUniform;
    opt.tying = WeightTying::kLayer;
    opt.height_gates = false;
    opt.epsilon = 1e-7;
    opt.c = c;
    const CalibrationResult res = Calibrate(db, q, opt, "d");
    const auto& w = res.weights.per_category.at("shirt");
    const double t = std::min(c, 5.0 / 80);
    for (int b = 0; b < L * R * S; ++b) {
      const double expect = 1 + t * (b < R * S ? 4 : -8);
      EXPECT_NEAR(w[b], expect, 1e-3) << "C " << c << " bit " << b;
    }
    EXPECT_EQ(res.categories[0].clipped, 0);
  }
  // A weight the closed form puts below 0 is set to 0 and counted: the relevant entry
  // 12 bits away (annuli 1, 2, 3), the nonrelevant one 4 (annulus 0).
  db_entries[0] = Labelled("rel", "A", "db", AnnulusCode(L, R, S, {1, 2, 3}));
  CalibrateOptions opt;
  opt.tying = WeightTying::kLayer;
  opt.regularizer = Regularizer::kUniform;
  opt.height_gates = false;
  opt.epsilon = 1e-7;
  opt.c = 100;
  // Layers: z_r = (4, 8), z_n = (4, 0) → a = (0, −8), 1·a = −8, t = 9/64: v = (1, 1 − 72/64) < 0.
  const CalibrationResult res = Calibrate(Database(db_entries), q, opt, "d");
  const auto& w = res.weights.per_category.at("shirt");
  EXPECT_NEAR(w[0], 1, 1e-3);
  EXPECT_EQ(w[static_cast<size_t>(R) * S], 0);
  EXPECT_EQ(res.categories[0].clipped, R * S);
}

// δ penalised infinitely (C = 0, or C → 0): the learned ranking is the unweighted one.
TEST(RecognitionCalibrate, UniformPriorWithCZeroRanksAsUnweighted) {
  Rng rng(DeriveSeed(42, "prior-limit"));
  NoisyCategory cat(rng);
  std::vector<LabelledCode> train, calib, test;
  for (int a = 0; a < NoisyCategory::kAnchors; ++a) {
    const std::string an = "anchor" + std::to_string(a);
    for (int inst = 1; inst <= 2; ++inst)
      train.push_back(
          Labelled("t" + an + std::to_string(inst), an, "shirt-" + std::to_string(inst), cat.Sample(rng, a, 4)));
    for (int j = 0; j < 3; ++j) {
      calib.push_back(Labelled("c" + an + std::to_string(j), an, "shirt-c", cat.Sample(rng, a, 8)));
      test.push_back(Labelled("q" + an + std::to_string(j), an, "shirt-q", cat.Sample(rng, a, 8)));
    }
  }
  const Database db(train);
  CalibrateOptions opt;
  opt.regularizer = Regularizer::kUniform;
  for (WeightTying t : {WeightTying::kBit, WeightTying::kAnnulus, WeightTying::kLayer}) {
    opt.tying = t;
    opt.c = 0;
    const CalibrationResult zero = Calibrate(db, calib, opt, "d");
    EXPECT_EQ(zero.weights.per_category.at("shirt"), std::vector<double>(size_t{16} * 16 * 16, 1.0));
    Recognizer unweighted(db, nullptr), learned(db, &zero.weights);
    RecognizeOptions ro;
    ro.top_k = 100;
    for (const auto& q : test) {
      const Recognition u = unweighted.Recognize(q.code, ro), l = learned.Recognize(q.code, ro);
      ASSERT_EQ(u.top.size(), l.top.size());
      for (size_t k = 0; k < u.top.size(); ++k) EXPECT_EQ(u.top[k].entry, l.top[k].entry);
    }
    // C → 0: w → 1, and every pair of entries the Hamming distance orders keeps its order.
    opt.c = 1e-6;
    const CalibrationResult tiny = Calibrate(db, calib, opt, "d");
    const auto& w = tiny.weights.per_category.at("shirt");
    for (double v : w) ASSERT_NEAR(v, 1, 1e-4);
    for (const auto& q : test) {
      const PreparedQuery pq(q.code);
      std::vector<Match> m;
      db.matcher().MatchAll(pq, &m);
      PreparedWeights pw(w, 16, 16, 16, WeightFrame::kDatabase);
      for (int i = 0; i < db.size(); ++i)
        for (int j = 0; j < db.size(); ++j) {
          if (m[i].distance < m[j].distance) {
            EXPECT_LT(db.matcher().Weighted(i, pq, m[i].rotation, pw), db.matcher().Weighted(j, pq, m[j].rotation, pw));
          }
        }
    }
  }
}

// One informative block (the upper layers), noise in the rest: the uniform prior raises
// the informative layers' weights above the noise layers', keeps annulus weights equal
// across sectors, and beats the unweighted distance on new queries; cross-validation
// (leave one instance out) prefers a learned setting to the unweighted distance.
TEST(RecognitionCalibrate, UniformPriorRaisesTheInformativeBlock) {
  Rng rng(DeriveSeed(42, "informative-block"));
  NoisyCategory cat(rng);
  std::vector<LabelledCode> train, calib, test;
  for (int a = 0; a < NoisyCategory::kAnchors; ++a) {
    const std::string an = "anchor" + std::to_string(a);
    for (int inst = 1; inst <= 2; ++inst)
      train.push_back(
          Labelled("t" + an + std::to_string(inst), an, "shirt-" + std::to_string(inst), cat.Sample(rng, a, 4)));
    for (int j = 0; j < 5; ++j) {
      calib.push_back(Labelled("c" + an + std::to_string(j), an, "shirt-c", cat.Sample(rng, a, 8)));
      test.push_back(Labelled("q" + an + std::to_string(j), an, "shirt-q",
                              Rotate(cat.Sample(rng, a, 8), static_cast<int>(rng.Below(16)))));
    }
  }
  const Database db(train);
  CalibrateOptions opt;
  opt.regularizer = Regularizer::kUniform;
  opt.tying = WeightTying::kAnnulus;
  opt.c = 10;
  const CalibrationResult res = Calibrate(db, calib, opt, "d");
  const auto& w = res.weights.per_category.at("shirt");
  const int half = 8 * 16 * 16;
  double up = 0, down = 0;
  for (int b = 0; b < half; ++b) up += w[b];
  for (int b = half; b < 2 * half; ++b) down += w[b];
  EXPECT_GT(up / half, 1.0);
  EXPECT_LT(down / half, 1.0);
  for (int b = 0; b < 2 * half; ++b)
    ASSERT_EQ(w[b], w[static_cast<size_t>(b / 16) * 16]) << "annulus weights differ across sectors";
  Recognizer unweighted(db, nullptr), learned(db, &res.weights);
  int err_u = 0, err_w = 0;
  for (const auto& q : test) {
    err_u += unweighted.Recognize(q.code, {}).anchor != q.label.anchor;
    err_w += learned.Recognize(q.code, {}).anchor != q.label.anchor;
  }
  std::printf("informative block: unweighted %d/40 wrong, learned (annulus, C = 10) %d/40; mean w %.2f / %.2f\n", err_u,
              err_w, up / half, down / half);
  EXPECT_LT(err_w, err_u);

  // Cross-validation over calibration + train (three instances: shirt-1, shirt-2, shirt-c).
  std::vector<LabelledCode> cvq = calib;
  cvq.insert(cvq.end(), train.begin(), train.end());
  const CrossValidation cv = CrossValidate(db, cvq, opt, {}, DefaultCvGrid());
  EXPECT_EQ(cv.folds, 3);
  EXPECT_EQ(cv.queries, 40 + 16);
  ASSERT_GE(cv.chosen, 0);
  EXPECT_GT(cv.settings[cv.chosen].c, 0) << "a learned setting should win here";
  EXPECT_GT(cv.settings[cv.chosen].right, cv.settings[0].right);
  EXPECT_EQ(cv.settings[0].c, 0);
}

// Cross-validation never lets a held-out instance's entries into a training pair: with
// two database instances and queries of those instances only, holding one out leaves the
// other with no instance to rank against, so every learned setting falls back to w = 1
// and scores exactly as the unweighted distance.
TEST(RecognitionCalibrate, CrossValidationHoldsTheInstanceOutOfTraining) {
  Rng rng(11);
  NoisyCategory cat(rng);
  std::vector<LabelledCode> train;
  for (int a = 0; a < 4; ++a)
    for (int inst = 1; inst <= 2; ++inst)
      train.push_back(Labelled("t" + std::to_string(a) + std::to_string(inst), "a" + std::to_string(a),
                               "shirt-" + std::to_string(inst), cat.Sample(rng, a, 4)));
  const CrossValidation cv = CrossValidate(Database(train), train, {}, {}, DefaultCvGrid());
  EXPECT_EQ(cv.folds, 2);
  EXPECT_EQ(cv.queries, 8);
  for (const auto& s : cv.settings) EXPECT_EQ(s.right, cv.settings[0].right) << s.Name();
  EXPECT_EQ(cv.chosen, 0);  // ties: the simplest, the unweighted distance
}

TEST(RecognitionCalibrate, WeightsRoundTripAndForeignDigestIsRefused) {
  const fs::path dir = fs::temp_directory_path() / ("drape_weights_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  Weights w;
  w.release_digest = "aaaa";
  w.layers = 2;
  w.rings = 2;
  w.sectors = 4;
  w.per_category["pants"] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15.5};
  SaveWeights(w, dir);
  const Weights back = LoadWeights(dir, "aaaa");
  EXPECT_EQ(back.per_category.at("pants"), w.per_category.at("pants"));
  try {
    LoadWeights(dir, "bbbb");
    FAIL();
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("learned on release digest aaaa"), std::string::npos) << m;
    EXPECT_NE(m.find("bbbb"), std::string::npos) << m;
  }
  // A flipped byte in weights.bin is caught.
  std::string bin = ReadFile(dir / "weights.bin");
  bin[5] ^= 1;
  WriteFileAtomic(dir / "weights.bin", bin);
  EXPECT_THROW(LoadWeights(dir, "aaaa"), Error);
  EXPECT_THROW(LoadWeights(dir / "nope", "aaaa"), Error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace drape::recognition
