// The code version (git describe) this binary was built from; recorded in releases.
#pragma once

namespace drape {
const char* GitVersion();
}  // namespace drape
