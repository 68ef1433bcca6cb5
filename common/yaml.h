// YAML text parsed with a syntax error reported as file:line:col, shared by the recipe
// (generator/recipe) and folding plan (runtime/folding) parsers. Header-only: the
// targets that include it link yaml-cpp themselves; drape_common does not.
#pragma once

#include <yaml-cpp/yaml.h>

#include <sstream>
#include <string>

#include "common/error.h"

namespace drape {

// The parsed document; a syntax error is a drape::Error "LABEL:LINE:COL: YAML syntax
// error: ..." (1-based line and column).
inline YAML::Node LoadYaml(const std::string& text, const std::string& file_label) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    std::ostringstream os;
    os << file_label << ":" << e.mark.line + 1 << ":" << e.mark.column + 1 << ": YAML syntax error: " << e.msg;
    throw Error(os.str());
  }
}

}  // namespace drape
