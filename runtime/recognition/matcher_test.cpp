#include "runtime/recognition/matcher.h"

#include <gtest/gtest.h>

#include <tuple>

#include "common/error.h"
#include "common/rng.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/recognition/test_features.h"

namespace drape::recognition {
namespace {

std::vector<Kernel> AvailableKernels() {
  std::vector<Kernel> ks;
  for (Kernel k : {Kernel::kGeneric, Kernel::kPopcnt, Kernel::kAvx512}) {
    if (KernelAvailable(k)) ks.push_back(k);
  }
  return ks;
}

TEST(RecognitionMatcher, RotationComposesAndPermutes) {
  Rng rng(1);
  const Code x = RandomCode(rng, 3, 4, 7);
  EXPECT_EQ(Rotate(x, 7).words, x.words);
  EXPECT_EQ(Rotate(Rotate(x, 3), 5).words, Rotate(x, 8).words);
  EXPECT_EQ(Rotate(Rotate(x, 3), -3).words, x.words);
  // Sector s of (layer, ring) moves to s + k: check one bit by hand.
  Code one = ZeroFeature(2, 2, 5);
  one.Set((1 * 2 + 1) * 5 + 4, true);  // l=1, r=1, s=4
  const Code rot = Rotate(one, 2);
  EXPECT_TRUE(rot.Get((1 * 2 + 1) * 5 + 1));  // s = (4+2) mod 5 = 1
  EXPECT_EQ(std::popcount(rot.words[0]), 1);
}

// The fast matcher equals the bit-by-bit reference on random features, for every
// kernel this CPU has, several shapes (Φ = 3, 7, 10, 16, 64; bit counts not multiples
// of 64), and queries that are rotated + noisy copies of a database entry.
TEST(RecognitionMatcher, FastEqualsReferenceAllRotations) {
  const std::vector<std::tuple<int, int, int>> shapes = {{16, 16, 16}, {4, 5, 10}, {3, 3, 7},
                                                         {2, 1, 64},   {1, 1, 3},  {5, 3, 16}};
  for (auto [l, r, s] : shapes) {
    Rng rng(DeriveSeed(7, std::to_string(l * 10000 + r * 100 + s)));
    std::vector<Code> db;
    db.reserve(12);
    for (int i = 0; i < 12; ++i) db.push_back(RandomCode(rng, l, r, s, 0.3 + 0.04 * i));
    std::vector<Code> queries;
    for (int k = 0; k < s; ++k) {
      // Exactly rotated copy: the reference finds k (or a rotation with the same distance).
      queries.push_back(Rotate(db[k % db.size()], k));
      queries.push_back(FlipBits(Rotate(db[(k + 3) % db.size()], k), rng, 1 + k % 5));
    }
    queries.push_back(RandomCode(rng, l, r, s));
    for (Kernel kern : AvailableKernels()) {
      Matcher m(l, r, s, kern);
      for (size_t i = 0; i < db.size(); ++i) m.Add(db[i], "db" + std::to_string(i));
      std::vector<Match> got;
      for (const Code& q : queries) {
        m.MatchAll(PreparedQuery(q), &got);
        ASSERT_EQ(got.size(), db.size());
        for (size_t i = 0; i < db.size(); ++i) {
          const Match ref = DistanceReference(db[i], q);
          ASSERT_EQ(got[i].distance, ref.distance) << KernelName(kern) << " shape " << l << "x" << r << "x" << s;
          ASSERT_EQ(got[i].rotation, ref.rotation) << KernelName(kern);
        }
      }
    }
    // A pure rotation is found exactly.
    for (int k = 0; k < s; ++k) {
      const Match ref = DistanceReference(db[0], Rotate(db[0], k));
      EXPECT_EQ(ref.distance, 0);
      EXPECT_EQ(Rotate(db[0], ref.rotation).words, Rotate(db[0], k).words);
    }
  }
}

TEST(RecognitionMatcher, WeightedAndXorVectorEqualReference) {
  Rng rng(3);
  const int l = 4, r = 3, s = 10;
  Matcher m(l, r, s);
  std::vector<Code> db;
  for (int i = 0; i < 6; ++i) {
    db.push_back(RandomCode(rng, l, r, s));
    m.Add(db.back(), "db");
  }
  // Integer weights: sums are exact in any order.
  std::vector<double> w(static_cast<size_t>(l) * r * s);
  for (double& v : w) v = static_cast<double>(rng.Below(9));
  const Code q = RandomCode(rng, l, r, s);
  PreparedQuery pq(q);
  for (WeightFrame frame : {WeightFrame::kQuery, WeightFrame::kDatabase}) {
    const bool qf = frame == WeightFrame::kQuery;
    PreparedWeights pw(w, l, r, s, frame);
    for (int i = 0; i < 6; ++i) {
      for (int k = 0; k < s; ++k) {
        EXPECT_EQ(m.Weighted(i, pq, k, pw), WeightedDistanceReference(db[i], k, q, w, qf));
        std::vector<double> x;
        m.XorVector(i, pq, k, frame, &x);
        const Code a = qf ? Rotate(db[i], k) : db[i];
        const Code b = qf ? q : Rotate(q, -k);
        for (int j = 0; j < l * r * s; ++j) ASSERT_EQ(x[j], a.Get(j) != b.Get(j) ? 1.0 : 0.0);
      }
    }
  }
  // The database-frame weighted distance is invariant to turning the query.
  PreparedWeights pw(w, l, r, s, WeightFrame::kDatabase);
  const PreparedQuery turned(Rotate(q, 3));
  for (int i = 0; i < 6; ++i) {
    for (int k = 0; k < s; ++k) EXPECT_EQ(m.Weighted(i, pq, k, pw), m.Weighted(i, turned, (k + 3) % s, pw));
  }
}

TEST(RecognitionMatcher, ShapeErrorsAreClear) {
  Matcher m(4, 4, 8);
  Code bad = ZeroFeature(4, 4, 8);
  bad.words.pop_back();
  try {
    m.Add(bad, "entry e7");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("entry e7"), std::string::npos) << e.what();
  }
  EXPECT_THROW(m.Add(ZeroFeature(4, 4, 16), "entry e8"), Error);
  m.Add(ZeroFeature(4, 4, 8), "ok");
  std::vector<Match> out;
  try {
    m.MatchAll(PreparedQuery(ZeroFeature(4, 8, 4)), &out);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("differs from the database"), std::string::npos) << e.what();
  }
}

Database SmallDb(Rng& rng, std::vector<Code>* protos) {
  std::vector<LabelledCode> v;
  const char* anchors[] = {"a", "b", "c"};
  for (int a = 0; a < 3; ++a) {
    protos->push_back(RandomCode(rng, 4, 4, 8));
    for (int inst = 1; inst <= 2; ++inst) {
      LabelledCode lc;
      lc.label.id = "e" + std::to_string(a * 2 + inst);
      lc.label.category = "pants";
      lc.label.instance = "pants-" + std::to_string(inst);
      lc.label.anchor = anchors[a];
      lc.code = FlipBits(protos->back(), rng, 3);
      v.push_back(lc);
    }
  }
  LabelledCode other;
  other.label = {"s1", "train", "shorts", "shorts-1", "a", "", -1, {}, {}};
  other.code = RandomCode(rng, 4, 4, 8);
  v.push_back(other);
  return Database(std::move(v));
}

TEST(RecognitionRecognizer, FindsAnchorCategoryAndRotation) {
  Rng rng(11);
  std::vector<Code> protos;
  Database db = SmallDb(rng, &protos);
  Recognizer rec(db, nullptr);
  RecognizeOptions o;
  o.top_k = 3;
  const Recognition r = rec.Recognize(Rotate(FlipBits(protos[1], rng, 2), 5), o);
  EXPECT_EQ(r.category, "pants");
  EXPECT_EQ(r.category_source, "unweighted_nn");
  EXPECT_EQ(r.anchor, "b");
  EXPECT_EQ(r.best.rotation, 5);
  ASSERT_EQ(r.top.size(), 3u);
  EXPECT_EQ(r.top[0].anchor, "b");
  EXPECT_NE(r.top[1].anchor, "b");
  EXPECT_NE(r.top[2].anchor, r.top[1].anchor);
  EXPECT_TRUE(r.entries.empty());  // listed only when asked for
  // The ranked entries: any anchor or instance, best first, the best one leading.
  o.top_entries = 4;
  const Recognition e = rec.Recognize(Rotate(FlipBits(protos[1], rng, 2), 5), o);
  ASSERT_EQ(e.entries.size(), 4u);
  EXPECT_EQ(e.entries[0].entry, e.best.entry);
  for (size_t i = 1; i < e.entries.size(); ++i) EXPECT_LE(e.entries[i - 1].score, e.entries[i].score);
  o.top_entries = 100;  // more than the pose pool: all of it (the 6 pants entries)
  EXPECT_EQ(rec.Recognize(protos[1], o).entries.size(), 6u);
  o.top_entries = -1;
  EXPECT_THROW(rec.Recognize(protos[1], o), Error);
  o.top_entries = 0;
  // Restricting to one instance keeps the answer inside it.
  o.instances = {"pants-2"};
  EXPECT_EQ(rec.Recognize(protos[1], o).best.instance, "pants-2");
  // Or to a set of instances (the pose pool: that instance's 3 entries, both instances' 6);
  // one the category lacks leaves no pool.
  o.top_entries = 100;
  EXPECT_EQ(rec.Recognize(protos[1], o).entries.size(), 3u);
  o.instances = {"pants-2", "pants-1"};
  EXPECT_EQ(rec.Recognize(protos[1], o).entries.size(), 6u);
  o.top_entries = 0;
  o.instances = {"pants-9"};
  EXPECT_THROW(rec.Recognize(protos[1], o), Error);
}

TEST(RecognitionRecognizer, EmptyDatabaseAndAbsentCategoryAreClearErrors) {
  Database empty;
  Recognizer r0(empty, nullptr);
  try {
    r0.Recognize(ZeroFeature(4, 4, 8), {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("database is empty"), std::string::npos) << e.what();
  }
  Rng rng(2);
  std::vector<Code> protos;
  Database db = SmallDb(rng, &protos);
  Recognizer rec(db, nullptr);
  RecognizeOptions o;
  o.category = "long_sleeve_shirt";
  try {
    rec.Recognize(protos[0], o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'long_sleeve_shirt' is not in the database"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("pants, shorts"), std::string::npos) << e.what();
  }
  o.category = "pants";
  o.instances = {"pants-9"};
  EXPECT_THROW(rec.Recognize(protos[0], o), Error);
}

}  // namespace
}  // namespace drape::recognition
