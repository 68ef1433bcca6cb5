// YAML text parsed with a syntax error reported as file:line:col, shared by the recipe
// (generator/recipe) and folding plan (runtime/folding) parsers. Header-only: the
// targets that include it link yaml-cpp themselves; drape_common does not.
#pragma once

#include <yaml-cpp/yaml.h>

#include <optional>
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

// How an error message names what a node holds: "nothing", "a mapping", "a list" or
// the scalar in quotes.
inline std::string DescribeYaml(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return "nothing";
  if (n.IsMap()) return "a mapping";
  if (n.IsSequence()) return "a list";
  return "'" + n.Scalar() + "'";
}

// A scalar read as a number (possibly not finite); nullopt for anything else.
inline std::optional<double> YamlNumber(const YAML::Node& n) {
  if (!n.IsScalar()) return std::nullopt;
  try {
    return n.as<double>();
  } catch (const YAML::Exception&) {
    return std::nullopt;
  }
}

}  // namespace drape
