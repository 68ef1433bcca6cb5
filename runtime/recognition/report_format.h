// Cells of the eval's markdown tables: internal to drape_recognition (eval_report.cpp,
// ladder.cpp and miss_curve.cpp write the same figures the same way).
#pragma once

#include <cstdio>
#include <string>

#include "common/json.h"

namespace drape::recognition {

// A share in [0, 1] as "42.1 %"; "n/a" for null (no query of that kind).
inline std::string PercentCell(const Json& v) {
  if (v.is_null()) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", 100.0 * v.get<double>());
  return buf;
}

}  // namespace drape::recognition
