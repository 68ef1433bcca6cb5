#include "common/version.h"

#include <fstream>
#include <string>
#include <thread>

#include "git_version.h"  // generated at build time by cmake/GitVersion.cmake

namespace drape {
namespace {

// The first "model name" line of /proc/cpuinfo (x86 Linux); "unknown" when there is none.
std::string CpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) break;
    const auto start = line.find_first_not_of(" \t", colon + 1);
    if (start == std::string::npos) break;
    return line.substr(start);
  }
  return "unknown";
}

}  // namespace

const char* GitVersion() { return DRAPE_GIT_VERSION; }

Json RunProvenance() {
  return Json{{"code_version", GitVersion()},
              {"cpu", CpuModel()},
              {"cores", static_cast<int>(std::thread::hardware_concurrency())}};
}

}  // namespace drape
