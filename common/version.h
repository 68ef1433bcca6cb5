// The code version (git describe) this binary was built from; recorded in releases.
#pragma once

#include "common/json.h"

namespace drape {
const char* GitVersion();

// Where a run happened: {"code_version": GitVersion(), "cpu": the CPU model name (from
// /proc/cpuinfo, "unknown" elsewhere), "cores": logical CPUs online}. Every command's
// report records it, so that a table made from reports (tools/results.py) states the code
// and the machine that produced its figures.
Json RunProvenance();
}  // namespace drape
