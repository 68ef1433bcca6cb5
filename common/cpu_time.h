// CPU time of the calling thread (s): what a piece of code cost, whatever else the
// machine runs (wall clocks on a shared machine count other processes' time too).
// For timing reports and benchmarks only; never part of a result that is hashed.
#pragma once

#include <ctime>

namespace drape {

inline double ThreadCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace drape
