// Wall-clock time (s) for timing reports: one clock and one conversion for every stage.
// Thread CPU time, which other processes on a shared machine do not inflate, is in
// cpu_time.h. For timing reports and benchmarks only; never part of a result that is hashed.
#pragma once

#include <chrono>

namespace drape {

// The monotonic clock every wall-time figure is taken with (never jumps with the system time).
using Clock = std::chrono::steady_clock;

// Seconds from a to b (negative if b is earlier): for laps that reuse one reading as the
// end of a step and the start of the next.
inline double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// Seconds elapsed since t0, a Clock::now() taken earlier.
inline double Since(Clock::time_point t0) { return Seconds(t0, Clock::now()); }

// Clock's reading in seconds, for laps kept as doubles. A read costs ~0.1 µs (vDSO); a CPU
// clock (cpu_time.h) is a system call, ~6 µs on a loaded 2-core VM: too much for the
// phases of a 0.3 ms simulation step. Time those with this and scale the sum of a long
// run to the thread CPU time read once around it (as the hang does).
inline double ClockSeconds() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }

}  // namespace drape
