#include "common/version.h"

#include "git_version.h"  // generated at build time by cmake/GitVersion.cmake

namespace drape {
const char* GitVersion() { return DRAPE_GIT_VERSION; }
}  // namespace drape
