#include "common/option_keys.h"

#include <algorithm>
#include <cstdio>

namespace drape {

int EditDistance(const std::string& a, const std::string& b) {
  std::vector<int> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = static_cast<int>(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    int diag = row[0];
    row[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j) {
      const int up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string Suggest(const std::string& got, const std::vector<std::string>& known) {
  std::string best;
  int best_d = 1 << 30;
  for (const auto& k : known) {
    const int d = EditDistance(got, k);
    if (d < best_d) best_d = d, best = k;
  }
  if (!best.empty() && best_d <= std::max<int>(2, static_cast<int>(got.size()) / 3))
    return " (did you mean '" + best + "'?)";
  return "";
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string s;
  for (size_t i = 0; i < names.size(); ++i) s += (i ? ", " : "") + names[i];
  return s;
}

std::string FormatOptionValue(const OptionRef& r) {
  struct V {
    std::string operator()(double* d) const {
      char b[32];
      std::snprintf(b, sizeof b, "%g", *d);
      return b;
    }
    std::string operator()(int* i) const { return std::to_string(*i); }
    std::string operator()(bool* b) const { return *b ? "true" : "false"; }
    std::string operator()(std::string* s) const { return s->empty() ? "\"\"" : *s; }
  };
  return std::visit(V{}, r);
}

std::string KeysMarkdown(const OptionSectionDoc& section) {
  std::string md = "| key | default | unit | meaning |\n|---|---|---|---|\n";
  for (const auto& k : section.keys)
    md += "| `" + k.key + "` | " + k.default_value + " | " + k.unit + " | " + k.meaning + " |\n";
  return md;
}

}  // namespace drape
