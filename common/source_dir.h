// The repository the build was configured from, for tests and benchmarks that read its
// fixtures (testdata folders, docs, plans). Only source_dir.cpp is compiled with the
// path, so every other compile command is the same in any clone and ccache (base_dir)
// serves a second clone's build from the first one's objects.
#pragma once

#include <filesystem>

namespace drape {

std::filesystem::path SourceDir();

}  // namespace drape
