// One release entry as the build produces it and the release writer stores it.
#pragma once

#include <string>
#include <vector>

#include "common/json.h"

namespace drape {

struct EntryFile {
  std::string path;   // relative to entries/<id>/, e.g. "hang.ply", "sweep/000000.png"
  std::string bytes;  // deterministic content
};

struct Entry {
  std::string id;     // stable folder name under entries/
  std::string key;    // the job key it came from (unique in a recipe)
  std::string split;  // "train" | "calibration" | "test"
  bool failed = false;
  std::string failure;  // reason, when failed
  Json record;          // canonical catalog fields; part of the release digest
  Json timing;          // wall-clock timings and machine facts; never hashed
  std::vector<EntryFile> files;
};

}  // namespace drape
