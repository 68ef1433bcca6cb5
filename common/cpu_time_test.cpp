#include "common/cpu_time.h"

#include <gtest/gtest.h>

namespace drape {
namespace {

TEST(ThreadCpuSeconds, IsMonotone) {
  const double a = ThreadCpuSeconds(), b = ThreadCpuSeconds(), c = ThreadCpuSeconds();
  EXPECT_GE(a, 0.0);
  EXPECT_LE(a, b);
  EXPECT_LE(b, c);
}

TEST(ProcessCpuSeconds, IsMonotone) {
  const double a = ProcessCpuSeconds(), b = ProcessCpuSeconds(), c = ProcessCpuSeconds();
  EXPECT_GE(a, 0.0);
  EXPECT_LE(a, b);
  EXPECT_LE(b, c);
}

TEST(ProcessCpuSeconds, CountsThisThreadsBusyLoop) {
  // No timing threshold: spin until this thread has used 20 ms of CPU (however long that
  // takes on a busy machine); the process, whose CPU time includes this thread's, has used
  // at least as much, give or take one scheduler tick (10 ms) where its clock is sampled
  // at ticks.
  const double p0 = ProcessCpuSeconds(), t0 = ThreadCpuSeconds();
  volatile double sink = 0;
  double t1 = t0;
  while (t1 - t0 < 0.020) {
    for (int i = 0; i < 10000; ++i) sink = sink + 1.0;
    t1 = ThreadCpuSeconds();
  }
  const double p1 = ProcessCpuSeconds();
  EXPECT_GT(p1, p0);
  EXPECT_GE(p1 - p0, (t1 - t0) - 0.010);
}

}  // namespace
}  // namespace drape
