// File helpers: whole-file reads and atomic writes (temporary name, then rename),
// so that an interrupted build never leaves a half-written file under its real name.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace drape {

// Throws drape::Error naming the path.
std::string ReadFile(const std::filesystem::path& path);
// Writes `bytes` to path.tmp.<pid>, fsyncs, renames over `path`. Creates parent folders.
void WriteFileAtomic(const std::filesystem::path& path, std::string_view bytes);

}  // namespace drape
