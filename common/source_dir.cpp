#include "common/source_dir.h"

namespace drape {

std::filesystem::path SourceDir() { return DRAPE_SOURCE_DIR; }

}  // namespace drape
