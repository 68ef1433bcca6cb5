// Numbers in messages as a person writes them: 10 (not 10.000000), 0.25, 1e-09.
#pragma once

#include <string>

namespace drape {

// Shortest text that reads back as the same double (std::to_chars): 10, 0.1, 2.5e-07,
// inf, nan. Use it instead of std::to_string(double) in messages.
std::string FormatNumber(double x);

// A measured value with `digits` decimals: FormatFixed(26.7874, 1) = "26.8". Use it
// for measurements, whose full precision is noise to the reader.
std::string FormatFixed(double x, int digits);

}  // namespace drape
