// JSON for every file drape writes. ordered_json keeps keys in insertion order so
// that written files, and the hashes over them, are byte-stable.
#pragma once

#include <nlohmann/json.hpp>

namespace drape {
using Json = nlohmann::ordered_json;
}  // namespace drape
