#include "common/files.h"

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/parallel.h"

namespace drape {
namespace {

TEST(Files, AtomicWriteRoundTripAndNoTemporaryLeft) {
  const auto dir = std::filesystem::temp_directory_path() / "drape_files_test";
  std::filesystem::remove_all(dir);
  const auto p = dir / "sub" / "x.bin";
  WriteFileAtomic(p, std::string("a\0b", 3));
  EXPECT_EQ(ReadFile(p), std::string("a\0b", 3));
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(dir / "sub")) n += e.is_regular_file();
  EXPECT_EQ(n, 1);
  EXPECT_THROW(ReadFile(dir / "missing"), Error);
  std::filesystem::remove_all(dir);
}

TEST(Parallel, EveryIndexOnceAndFirstErrorRethrown) {
  std::vector<int> hits(1000, 0);
  ParallelFor(1000, 2, [&](int i) { hits[i]++; });
  for (int h : hits) EXPECT_EQ(h, 1);
  EXPECT_THROW(ParallelFor(10, 2,
                           [](int i) {
                             if (i == 3) throw Error("x");
                           }),
               Error);
}

}  // namespace
}  // namespace drape
