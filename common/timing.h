// Wall-clock time (s) for timing reports: one clock and one conversion for every stage.
// Thread CPU time, which other processes on a shared machine do not inflate, is in
// cpu_time.h. For timing reports and benchmarks only; never part of a result that is hashed.
#pragma once

#include <chrono>

namespace drape {

// The monotonic clock every wall-time figure is taken with (never jumps with the system time).
using Clock = std::chrono::steady_clock;

// Seconds elapsed since t0, a Clock::now() taken earlier.
inline double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace drape
