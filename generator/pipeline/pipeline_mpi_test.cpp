#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>

#include "common/error.h"
#include "common/hash.h"
#include "generator/pipeline/build_mpi.h"
#include "generator/release/release.h"

namespace drape {
namespace {

Entry SampleEntry() {
  Entry e;
  e.id = "00003-towel-i0-towel_b-corner_a";
  e.key = "towel/i0/towel_b/corner_a";
  e.split = "train";
  e.failed = false;
  e.failure = "";
  e.record = {{"category", "towel"},
              {"seed", std::numeric_limits<uint64_t>::max()},
              {"negative", -42},
              {"anchor", {{"label", "corner_a"}, {"vertex", 12}, {"uv", {0.1, 1.0 / 3.0}}}},
              {"fusion", {{"recon_to_truth_mean", 0.0012345678901234567}, {"tiny", 4.9e-324}}},
              {"unicode", "größe → 大"},
              {"empty", Json::object()},
              {"list", Json::array()}};
  e.timing = {{"hang", 1.25}, {"total", 3.5}};
  std::string binary;
  for (int i = 0; i < 1000; ++i) binary.push_back(static_cast<char>(i * 37));
  binary += std::string(5, '\0');
  e.files = {{"hang.ply", binary}, {"sweep/000000.png", "png"}, {"empty.bin", ""}};
  return e;
}

std::vector<Release::FileInfo> Infos(const Entry& e) {
  std::vector<Release::FileInfo> out;
  for (const auto& f : e.files) out.push_back({f.path, Sha256Hex(f.bytes), f.bytes.size()});
  return out;
}

TEST(SerializeEntry, RoundTripsEveryField) {
  const Entry e = SampleEntry();
  const Entry d = DeserializeEntry(SerializeEntry(e), "test");
  EXPECT_EQ(d.id, e.id);
  EXPECT_EQ(d.key, e.key);
  EXPECT_EQ(d.split, e.split);
  EXPECT_EQ(d.failed, e.failed);
  EXPECT_EQ(d.failure, e.failure);
  EXPECT_EQ(d.record.dump(), e.record.dump());  // order, exact doubles, uint64 max
  EXPECT_EQ(d.timing.dump(), e.timing.dump());
  EXPECT_EQ(d.record["fusion"]["tiny"].get<double>(), 4.9e-324);
  EXPECT_EQ(d.record["seed"].get<uint64_t>(), std::numeric_limits<uint64_t>::max());
  ASSERT_EQ(d.files.size(), e.files.size());
  for (size_t i = 0; i < e.files.size(); ++i) {
    EXPECT_EQ(d.files[i].path, e.files[i].path);
    EXPECT_EQ(d.files[i].bytes, e.files[i].bytes);
  }
  // What the release digest sees is unchanged.
  EXPECT_EQ(EntryDigest(d.id, d.key, d.split, d.failed, d.failure, d.record, Infos(d)),
            EntryDigest(e.id, e.key, e.split, e.failed, e.failure, e.record, Infos(e)));
  // Serializing is deterministic.
  EXPECT_EQ(SerializeEntry(d), SerializeEntry(e));
}

TEST(SerializeEntry, FailedEntryAndNonFiniteNumbers) {
  Entry e;
  e.id = "00000-x";
  e.key = "x";
  e.split = "test";
  e.failed = true;
  e.failure = "hang: not settled";
  e.record = {{"nan", std::nan("")}, {"inf", -std::numeric_limits<double>::infinity()}};
  const Entry d = DeserializeEntry(SerializeEntry(e), "test");
  EXPECT_TRUE(d.failed);
  EXPECT_EQ(d.failure, e.failure);
  EXPECT_TRUE(std::isnan(d.record["nan"].get<double>()));
  EXPECT_EQ(d.record["inf"].get<double>(), -std::numeric_limits<double>::infinity());
  EXPECT_TRUE(d.timing.is_null());
  EXPECT_TRUE(d.files.empty());
}

TEST(SerializeEntry, RejectsEveryTruncationAndTrailingBytes) {
  const std::string bytes = SerializeEntry(SampleEntry());
  for (size_t n = 0; n < bytes.size(); n += (n < 200 ? 1 : 97)) {
    EXPECT_THROW(DeserializeEntry(std::string_view(bytes).substr(0, n), "cut"), Error) << n;
  }
  EXPECT_THROW(DeserializeEntry(bytes + "x", "long"), Error);
  std::string bad = bytes;
  bad[0] = 'X';
  try {
    DeserializeEntry(bad, "rank 2");
    FAIL() << "bad magic accepted";
  } catch (const Error& ex) {
    EXPECT_NE(std::string(ex.what()).find("rank 2"), std::string::npos) << ex.what();
  }
}

TEST(MpiRequested, FollowsTheLauncherEnvironment) {
  unsetenv("DRAPE_MPI");
  unsetenv("OMPI_COMM_WORLD_SIZE");
  EXPECT_FALSE(MpiRequested());
  setenv("OMPI_COMM_WORLD_SIZE", "1", 1);
  EXPECT_FALSE(MpiRequested());  // mpirun -np 1: a plain build
  setenv("OMPI_COMM_WORLD_SIZE", "3", 1);
  EXPECT_TRUE(MpiRequested());
  setenv("DRAPE_MPI", "0", 1);
  EXPECT_FALSE(MpiRequested());
  unsetenv("OMPI_COMM_WORLD_SIZE");
  setenv("DRAPE_MPI", "1", 1);
  EXPECT_TRUE(MpiRequested());
  unsetenv("DRAPE_MPI");
  setenv("OMPI_COMM_WORLD_RANK", "2", 1);
  EXPECT_EQ(MpiLaunchRank(), 2);
  unsetenv("OMPI_COMM_WORLD_RANK");
}

}  // namespace
}  // namespace drape
