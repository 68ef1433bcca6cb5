// A deterministic parallel loop: each index is independent, so results do not
// depend on the thread count. Callers keep per-index state (one Bullet world, one
// Rng seeded by DeriveSeed(seed, key) per job) so nothing is shared between indices.
#pragma once

#include <functional>

namespace drape {

// Number of hardware threads (at least 1).
int HardwareThreads();

// Calls fn(i) for i in [0, n) on `threads` threads (<= 0: all cores), handing out
// indices dynamically. An exception from fn stops handing out new indices and is
// rethrown (the first one by index order) once all threads have finished.
void ParallelFor(int n, int threads, const std::function<void(int)>& fn);

}  // namespace drape
