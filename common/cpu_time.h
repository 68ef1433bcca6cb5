// CPU time (s) of the calling thread, or of the whole process (all its threads): what a
// piece of code cost, whatever else the machine runs (wall clocks on a shared machine
// count other processes' time too). Wall time is in timing.h.
// For timing reports and benchmarks only; never part of a result that is hashed.
#pragma once

#include <ctime>

namespace drape {

inline double ThreadCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// CPU time of the whole process: every thread's, including ones that have ended.
inline double ProcessCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace drape
