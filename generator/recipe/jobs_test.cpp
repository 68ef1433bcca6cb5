#include "generator/recipe/jobs.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <regex>
#include <set>

#include "common/error.h"
#include "common/rng.h"
#include "common/source_dir.h"

namespace drape {
namespace {

Recipe Parse(const std::string& text) { return ParseRecipe(text, "mem.yaml", "/tmp"); }

const char* kRecipe = R"(
name: jobs
version: 1.0.0
seed: 11
garments:
  - template: towel
    instances: 4
    materials: [towel_a, towel_b]
  - template: pants
    instances: 2
    materials: [pants]
splits:
  train:
    garments: [{garment: towel, instances: [0, 1]}, {garment: pants, instances: [0]}]
  calibration:
    garments: [{garment: towel, instances: [2], max_anchors: 2, materials: [towel_b]}]
    perturbation: {grasp_offset: 0.02, size_scale: [0.9, 1.1], material_jitter: 0.1}
  test:
    garments: [{garment: towel, instances: [3]}, {garment: pants, instances: [1]}]
    perturbation: {grasp_offset: 0.03}
    repeats: 2
)";

TEST(Jobs, ExpansionIsDeterministicWithStableKeysIdsAndSeeds) {
  const Recipe r = Parse(kRecipe);
  const auto a = ExpandJobs(r);
  const auto b = ExpandJobs(Parse(kRecipe));
  ASSERT_EQ(a.size(), b.size());
  const size_t towel_anchors = r.garments[0].anchor_labels.size();
  const size_t pants_anchors = r.garments[1].anchor_labels.size();
  EXPECT_EQ(a.size(), 2 * (2 * towel_anchors) + pants_anchors + 2 + 2 * (2 * towel_anchors + pants_anchors));
  std::set<std::string> keys, ids;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].index, static_cast<int>(i));
    EXPECT_EQ(a[i].key, b[i].key);
    EXPECT_EQ(a[i].id, b[i].id);
    EXPECT_EQ(a[i].seed, b[i].seed);
    EXPECT_EQ(a[i].seed, DeriveSeed(11, a[i].key));
    EXPECT_EQ(a[i].grasp_offset, b[i].grasp_offset);
    EXPECT_TRUE(keys.insert(a[i].key).second) << a[i].key;
    EXPECT_TRUE(ids.insert(a[i].id).second) << a[i].id;
    EXPECT_TRUE(std::regex_match(a[i].id, std::regex("[0-9]{5}-[A-Za-z0-9_.-]+"))) << a[i].id;
  }
  EXPECT_EQ(a[0].key, "towel/i0/towel_a/" + r.garments[0].anchor_labels[0]);
  EXPECT_EQ(a[0].id, "00000-towel-i0-towel_a-" + r.garments[0].anchor_labels[0]);
  EXPECT_EQ(a.back().key, "pants/i1/pants/" + r.garments[1].anchor_labels.back() + "/p1");
}

TEST(Jobs, SplitsAreByInstance) {
  const auto jobs = ExpandJobs(Parse(kRecipe));
  std::map<std::string, std::set<std::string>> split_of;
  std::map<std::string, int> per_split;
  for (const auto& j : jobs) {
    split_of[j.instance_name].insert(j.split);
    per_split[j.split]++;
  }
  for (const auto& [inst, s] : split_of) EXPECT_EQ(s.size(), 1u) << inst;
  EXPECT_EQ(*split_of["towel/i2"].begin(), "calibration");
  EXPECT_EQ(*split_of["pants/i1"].begin(), "test");
  EXPECT_EQ(per_split["calibration"], 2);  // max_anchors: 2, one material
}

TEST(Jobs, PerturbationsArePerInstanceOrPerJobAndOnlyOnTheirSplit) {
  const Recipe r = Parse(kRecipe);
  const auto jobs = ExpandJobs(r);
  const Material& towel_b = r.materials.at("towel_b");
  std::set<double> calib_scales;
  for (const auto& j : jobs) {
    if (j.split == "train") {
      EXPECT_EQ(j.size_scale, 1.0);
      EXPECT_EQ(j.grasp_offset, Vec2::Zero());
      EXPECT_EQ(j.material.stretch_percent, r.materials.at(j.material_name).stretch_percent);
    } else if (j.split == "calibration") {
      calib_scales.insert(j.size_scale);
      EXPECT_GE(j.size_scale, 0.9);
      EXPECT_LE(j.size_scale, 1.1);
      EXPECT_NEAR(j.grasp_offset.norm(), 0.02, 1e-12);
      EXPECT_NE(j.material.stretch_percent, towel_b.stretch_percent);
      EXPECT_NEAR(j.material.stretch_percent / towel_b.stretch_percent, 1.0, 0.1 + 1e-12);
    } else {
      EXPECT_NEAR(j.grasp_offset.norm(), 0.03, 1e-12);
      EXPECT_EQ(j.size_scale, 1.0);
    }
  }
  EXPECT_EQ(calib_scales.size(), 1u);  // one instance, one scale for all its anchors
  // Repeats of one anchor get different grasp directions.
  const Job* p0 = nullptr;
  for (const auto& j : jobs)
    if (j.split == "test" && j.repeat == 0) p0 = &j;
  ASSERT_NE(p0, nullptr);
  EXPECT_NE(jobs[p0->index + 1].grasp_offset, p0->grasp_offset);
}

TEST(Jobs, ShardsCoverEveryJobOnce) {
  const int n = 23;
  std::vector<int> seen(n, 0);
  for (int k = 1; k <= 4; ++k)
    for (int i : ShardJobs(n, k, 4)) seen[i]++;
  for (int c : seen) EXPECT_EQ(c, 1);
  EXPECT_THROW(ShardJobs(n, 0, 4), Error);
  EXPECT_THROW(ShardJobs(n, 5, 4), Error);
}

TEST(Jobs, DefaultSplitIsTrainWithEveryInstance) {
  const auto jobs =
      ExpandJobs(Parse("name: x\nversion: 1.0.0\nseed: 1\ngarments:\n  - template: towel\n    instances: 2\n    "
                       "materials: [towel_a]\n"));
  ASSERT_FALSE(jobs.empty());
  for (const auto& j : jobs) EXPECT_EQ(j.split, "train");
  EXPECT_EQ(jobs.back().instance, 1);
}

TEST(Jobs, SlugIsFilesystemSafe) {
  EXPECT_EQ(Slug("pants/i2/jeans/waist_left"), "pants-i2-jeans-waist_left");
  EXPECT_EQ(Slug("a b:c"), "a-b-c");
}

}  // namespace
}  // namespace drape

namespace drape {
namespace {

// Ladder rungs (test_<rung>) may re-use train instances: keys get the split prefix,
// hangs keep the database entry's seed, turn and gripper noise reach the jobs.
TEST(Jobs, LadderRungsReuseTheDatabaseHang) {
  const std::string text = std::string(kRecipe) + R"(  test_noise:
    garments: [{garment: pants, instances: [0]}]
    perturbation: {turn: true}
  test_pose:
    garments: [{garment: pants, instances: [0]}]
    perturbation: {turn: true, grasp_offset: 0.02, gripper_pose_noise: 1.5}
)";
  const Recipe r = Parse(text);
  ASSERT_EQ(r.splits.size(), 5u);
  EXPECT_EQ(r.splits[3].name, "test_noise");
  EXPECT_EQ(r.splits[3].sensing, "sensed");
  const std::vector<Job> jobs = ExpandJobs(r);
  std::map<std::string, const Job*> train;
  for (const auto& j : jobs) {
    if (j.split == "train") {
      train[j.key] = &j;
      EXPECT_EQ(j.hang_seed, DeriveSeed(j.seed, "hang"));  // unchanged for ordinary splits
      EXPECT_EQ(j.turn, 0);
    }
  }
  int rungs = 0;
  for (const auto& j : jobs) {
    if (j.split.rfind("test_", 0) != 0) continue;
    ++rungs;
    ASSERT_EQ(j.key.rfind(j.split + "/", 0), 0u) << j.key;
    const Job* db = train.at(j.key.substr(j.split.size() + 1));
    EXPECT_EQ(j.hang_seed, db->hang_seed);
    EXPECT_NE(j.seed, db->seed);
    EXPECT_GT(j.turn, 0);
    EXPECT_LT(j.turn, 2 * M_PI);
    EXPECT_EQ(j.pose_noise_degrees, j.split == "test_pose" ? 1.5 : 0.0);
    EXPECT_EQ(j.grasp_offset.norm() > 0, j.split == "test_pose");
  }
  EXPECT_EQ(rungs, 2 * 12);  // pants has 12 anchors
  EXPECT_THROW(Parse(std::string(kRecipe) + "  test_:\n    garments: [{garment: pants, instances: [0]}]\n"), Error);
  EXPECT_THROW(Parse(std::string(kRecipe) + "  testing:\n    garments: [{garment: pants, instances: [0]}]\n"), Error);
  // Gripper noise beyond 45° is rejected.
  EXPECT_THROW(
      Parse(
          std::string(kRecipe) +
          "  test_x:\n    garments: [{garment: pants, instances: [0]}]\n    perturbation: {gripper_pose_noise: 50}\n"),
      Error);
}

// A split with `unperturbed: true` holds each anchor's job of the unperturbed split (same
// key, seeds, material, no offset) followed by its perturbed repeats, all keyed /p<r>.
TEST(Jobs, UnperturbedJobPrecedesTheRepeatsAndHangsLikeThePlainSplit) {
  const std::string head = R"(
name: aug
version: 1.0.0
seed: 5
garments:
  - template: towel
    instances: 2
    materials: [towel_a]
splits:
  train:
    garments: [{garment: towel, instances: [0]}]
)";
  const auto plain = ExpandJobs(Parse(head));
  const Recipe r = Parse(head +
                         "    perturbation: {grasp_offset: 0.03, material_jitter: 0.1, size_scale: [0.9, 1.1]}\n"
                         "    repeats: 2\n    unperturbed: true\n");
  const auto jobs = ExpandJobs(r);
  ASSERT_EQ(jobs.size(), 3 * plain.size());
  for (size_t a = 0; a < plain.size(); ++a) {
    const Job& exact = jobs[3 * a];
    EXPECT_EQ(exact.key, plain[a].key);
    EXPECT_EQ(exact.seed, plain[a].seed);
    EXPECT_EQ(exact.hang_seed, plain[a].hang_seed);
    EXPECT_EQ(exact.grasp_offset, Vec2::Zero());
    EXPECT_EQ(exact.size_scale, 1.0);
    EXPECT_EQ(exact.material.stretch_percent, plain[a].material.stretch_percent);
    for (int rep = 0; rep < 2; ++rep) {
      const Job& p = jobs[3 * a + 1 + rep];
      EXPECT_EQ(p.key, plain[a].key + "/p" + std::to_string(rep));
      EXPECT_EQ(p.anchor, plain[a].anchor);
      EXPECT_EQ(p.repeat, rep);
      EXPECT_NEAR(p.grasp_offset.norm(), 0.03, 1e-12);
      EXPECT_NE(p.size_scale, 1.0);
      EXPECT_NE(p.material.stretch_percent, plain[a].material.stretch_percent);
    }
  }
  // One repeat still gets its /p0, so it never shares the unperturbed job's key.
  const auto one = ExpandJobs(Parse(head + "    perturbation: {grasp_offset: 0.03}\n    unperturbed: true\n"));
  ASSERT_EQ(one.size(), 2 * plain.size());
  EXPECT_EQ(one[1].key, plain[0].key + "/p0");
  // Without a perturbation the option would only duplicate jobs: an error naming it.
  try {
    Parse(head + "    unperturbed: true\n");
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("splits.train.unperturbed"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace drape

namespace drape {
namespace {

const char* kHangsHead = R"(
name: hangs
version: 1.0.0
seed: 9
garments:
  - template: towel
    instances: 3
    materials: [towel_a]
splits:
  train:
    garments: [{garment: towel, instances: [0]}]
)";

// hangs_per_anchor: hang 0 is the job of K = 1 (same key, seeds, grasp, material: a
// release built with K = 1 keeps its bytes); hangs k ≥ 1 are keyed /h<k>, hang with
// their own seed and draw their own variation.
TEST(Jobs, HangsPerAnchorKeepHangZeroAndVaryTheOthers) {
  const auto plain = ExpandJobs(Parse(kHangsHead));
  const auto one = ExpandJobs(Parse(std::string(kHangsHead) + "    hangs_per_anchor: 1\n"));
  ASSERT_EQ(one.size(), plain.size());
  for (size_t i = 0; i < plain.size(); ++i) EXPECT_EQ(one[i].key, plain[i].key);
  const Recipe r = Parse(std::string(kHangsHead) +
                         "    hangs_per_anchor: 3\n"
                         "    hang_variation: {grasp_miss: 0.01, material_jitter: 0.1, pickup_spin: 2}\n");
  const auto jobs = ExpandJobs(r);
  ASSERT_EQ(jobs.size(), 3 * plain.size());
  const Material& towel_a = r.materials.at("towel_a");
  for (size_t a = 0; a < plain.size(); ++a) {
    const Job& h0 = jobs[3 * a];
    EXPECT_EQ(h0.key, plain[a].key);
    EXPECT_EQ(h0.seed, plain[a].seed);
    EXPECT_EQ(h0.hang_seed, plain[a].hang_seed);
    EXPECT_EQ(h0.hang, 0);
    EXPECT_EQ(h0.grasp_offset, Vec2::Zero());
    EXPECT_EQ(h0.pickup_spin, Vec3::Zero());
    EXPECT_EQ(h0.material.stretch_percent, towel_a.stretch_percent);
    for (int k = 1; k < 3; ++k) {
      const Job& h = jobs[3 * a + k];
      EXPECT_EQ(h.key, plain[a].key + "/h" + std::to_string(k));
      EXPECT_EQ(h.anchor, plain[a].anchor);
      EXPECT_EQ(h.split, "train");
      EXPECT_EQ(h.hang, k);
      EXPECT_NE(h.hang_seed, h0.hang_seed);
      EXPECT_EQ(h.grasp_offset, h.hang_miss);
      EXPECT_GT(h.grasp_offset.norm(), 0);
      EXPECT_LT(h.grasp_offset.cwiseAbs().maxCoeff(), 0.06);  // 6 σ
      EXPECT_NE(h.material.stretch_percent, towel_a.stretch_percent);
      EXPECT_NEAR(h.material.stretch_percent / towel_a.stretch_percent, 1.0, 0.1 + 1e-12);
      EXPECT_NEAR(h.material.stretch_percent / towel_a.stretch_percent, 1 + h.hang_material_jitter[0], 1e-12);
      EXPECT_GT(h.pickup_spin.norm(), 0);
      EXPECT_LE(h.pickup_spin.cwiseAbs().maxCoeff(), 2.0);
    }
    EXPECT_NE(jobs[3 * a + 1].grasp_offset, jobs[3 * a + 2].grasp_offset);
  }
  // Setting one variation does not move another's draws.
  const auto miss_only =
      ExpandJobs(Parse(std::string(kHangsHead) + "    hangs_per_anchor: 3\n    hang_variation: {grasp_miss: 0.01}\n"));
  ASSERT_EQ(miss_only.size(), jobs.size());
  for (size_t i = 0; i < jobs.size(); ++i) {
    EXPECT_EQ(miss_only[i].grasp_offset, jobs[i].grasp_offset);
    EXPECT_EQ(miss_only[i].pickup_spin, Vec3::Zero());
  }
  // A variation with K = 1 would vary nothing: an error at its key.
  try {
    Parse(std::string(kHangsHead) + "    hang_variation: {grasp_miss: 0.01}\n");
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mem.yaml:12:21: splits.train.hang_variation"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Parse(std::string(kHangsHead) + "    hangs_per_anchor: 0\n"), Error);
  try {
    Parse(std::string(kHangsHead) + "    hangs_per_anchor: 2\n    hang_variation: {pickup_spin: 30}\n");
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("splits.train.hang_variation.pickup_spin: must be in [0, 20] rad/s"),
              std::string::npos)
        << e.what();
  }
}

// grasp_miss: a Gaussian miss per job, σ per axis; not with grasp_offset.
TEST(Jobs, GraspMissIsGaussianPerAxis) {
  const Recipe r = Parse(std::string(kHangsHead) + R"(  test:
    garments: [{garment: towel, instances: [2]}]
    perturbation: {grasp_miss: 0.01}
    repeats: 100
)");
  double sx = 0, sy = 0, sxx = 0, syy = 0;
  int n = 0;
  for (const Job& j : ExpandJobs(r)) {
    if (j.split != "test") continue;
    sx += j.grasp_offset.x(), sy += j.grasp_offset.y();
    sxx += j.grasp_offset.x() * j.grasp_offset.x(), syy += j.grasp_offset.y() * j.grasp_offset.y();
    ++n;
  }
  ASSERT_GE(n, 400);
  // Mean within 4 standard errors of 0, σ within 15 % of 1 cm, on each axis.
  EXPECT_LT(std::abs(sx / n), 4 * 0.01 / std::sqrt(n));
  EXPECT_LT(std::abs(sy / n), 4 * 0.01 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(sxx / n), 0.01, 0.0015);
  EXPECT_NEAR(std::sqrt(syy / n), 0.01, 0.0015);
  try {
    Parse(std::string(kHangsHead) +
          "  test:\n    garments: [{garment: towel, instances: [2]}]\n"
          "    perturbation: {grasp_miss: 0.01, grasp_offset: 0.02}\n");
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("splits.test.perturbation.grasp_miss: not together with grasp_offset"),
              std::string::npos)
        << e.what();
  }
}

// miss_curve: one split per level after test, the test split's jobs with the grasp that
// far from the anchor, one direction per anchor at every level, the test job's hang
// seed and material.
TEST(Jobs, MissCurveSplitsRepeatTheTestSplitAtEachMiss) {
  const Recipe r = Parse(std::string(kHangsHead) + R"(  test:
    garments: [{garment: towel, instances: [2]}]
    perturbation: {grasp_miss: 0.01, material_jitter: 0.1, turn: true}
    miss_curve: [0, 0.005, 0.01, 0.03]
  test_extra:
    garments: [{garment: towel, instances: [0]}]
)");
  std::vector<std::string> names;
  for (const auto& s : r.splits) names.push_back(s.name);
  EXPECT_EQ(names, (std::vector<std::string>{"train", "test", "test_miss_0mm", "test_miss_5mm", "test_miss_10mm",
                                             "test_miss_30mm", "test_extra"}));
  const auto jobs = ExpandJobs(r);
  std::map<std::string, const Job*> test;
  for (const auto& j : jobs)
    if (j.split == "test") test[j.key] = &j;
  ASSERT_FALSE(test.empty());
  std::map<std::string, Vec2> direction;  // per anchor, from the 5 mm level
  std::map<std::string, int> per_level;
  for (const auto& j : jobs) {
    if (j.split.rfind("test_miss_", 0) != 0) continue;
    per_level[j.split]++;
    const Job* t = test.at(j.key.substr(j.split.size() + 1));
    EXPECT_EQ(j.hang_seed, t->hang_seed);
    EXPECT_NE(j.seed, t->seed);
    EXPECT_EQ(j.material.stretch_percent, t->material.stretch_percent);
    EXPECT_GT(j.turn, 0);
    const double level = std::stoi(j.split.substr(10)) / 1000.0;
    EXPECT_NEAR(j.grasp_offset.norm(), level, 1e-12) << j.key;
    if (level > 0) {
      const Vec2 d = j.grasp_offset / level;
      auto [it, fresh] = direction.insert({j.anchor, d});
      if (!fresh) {
        EXPECT_NEAR((it->second - d).norm(), 0, 1e-12) << j.key;
      }
    }
  }
  for (const auto& [split, count] : per_level) EXPECT_EQ(count, static_cast<int>(test.size())) << split;
  EXPECT_EQ(per_level.size(), 4u);
  auto error = [&](const std::string& tail) {
    try {
      Parse(std::string(kHangsHead) + tail);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string test_head = "  test:\n    garments: [{garment: towel, instances: [2]}]\n";
  EXPECT_NE(error(test_head + "    miss_curve: [0, 0.0025]\n").find("miss_curve[1]: must be whole millimetres"),
            std::string::npos);
  EXPECT_NE(error(test_head + "    miss_curve: [0.01, 0.005]\n").find("miss_curve[1]: levels must be strictly"),
            std::string::npos);
  EXPECT_NE(error(test_head + "    miss_curve: []\n").find("miss_curve: the list is empty"), std::string::npos);
  EXPECT_NE(error(test_head + "    miss_curve: [0.01]\n  test_miss_10mm:\n" +
                  "    garments: [{garment: towel, instances: [1]}]\n")
                .find("splits.test_miss_10mm: this split is also made by splits.test.miss_curve"),
            std::string::npos);
  EXPECT_NE(error("    miss_curve: [0.01]\n").find("splits.train.miss_curve: only the test split"), std::string::npos);
}

// Every shipped recipe parses and expands; the paper recipe's test split is the protocol
// (a 1 cm Gaussian grasp miss, ±10 % material) with its miss curve after it.
TEST(Jobs, ShippedRecipesExpandAndThePaperTestIsTheProtocol) {
  for (const auto& f : std::filesystem::directory_iterator(SourceDir() / "recipes")) {
    if (f.path().extension() != ".yaml") continue;
    EXPECT_FALSE(ExpandJobs(LoadRecipe(f.path())).empty()) << f.path();
  }
  const Recipe paper = LoadRecipe(SourceDir() / "recipes/paper.yaml");
  std::map<std::string, int> per_split;
  for (const Job& j : ExpandJobs(paper)) per_split[j.split]++;
  const SplitSpec* test = nullptr;
  for (const auto& s : paper.splits)
    if (s.name == "test") test = &s;
  ASSERT_NE(test, nullptr);
  EXPECT_EQ(test->perturbation.grasp_miss, 0.01);
  EXPECT_EQ(test->perturbation.material_jitter, 0.1);
  for (const char* level : {"test_miss_0mm", "test_miss_5mm", "test_miss_10mm", "test_miss_20mm", "test_miss_30mm"})
    EXPECT_EQ(per_split[level], per_split["test"]) << level;
}

}  // namespace
}  // namespace drape
