// Key tables: the vocabulary of strict options files, shared by the recipe parser
// (generator/recipe) and the `drape --config` options file (cli/config.h). A table names
// each key once: the field it sets, its unit and its meaning. common/yaml_keys.h reads
// YAML through it; the documentation's key tables are generated from it (KeysDoc).
//
// Ranges are deliberately absent from the tables: each Options struct's Validate() owns them.
#pragma once

#include <functional>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

namespace drape {

// The field a scalar key sets.
using OptionRef = std::variant<double*, int*, bool*, std::string*>;

template <typename O>
struct OptionKey {
  std::string key;                   // "a.b" = key b of the sub-map a
  std::function<OptionRef(O&)> ref;  // empty: read by hand by the caller (lists, names, files)
  std::string unit;
  std::string doc;
  std::string scope = "";  // a note on where it applies ("templates", "imports"), shown in the docs
};

// A member, or a member of a member: Ref(&SensingSpec::sweep, &SweepOptions::frames).
template <typename O, typename T, typename... M>
std::function<OptionRef(O&)> Ref(T O::*first, M... rest) {
  return [=](O& o) -> OptionRef { return &((o.*first).*....*rest); };
}

// Levenshtein edit distance, for "did you mean" suggestions.
int EditDistance(const std::string& a, const std::string& b);
// " (did you mean 'x'?)" when a candidate is close enough to be a plausible typo, else "".
std::string Suggest(const std::string& got, const std::vector<std::string>& known);
// "a, b, c".
std::string JoinNames(const std::vector<std::string>& names);

// A key table as documentation: each key with its default (from a default-constructed
// struct), unit and meaning; KeysMarkdown gives the table a README pastes.
struct OptionKeyDoc {
  std::string key, default_value, unit, meaning;
};
struct OptionSectionDoc {
  std::string name;
  std::vector<OptionKeyDoc> keys;
};
std::string FormatOptionValue(const OptionRef& r);
std::string KeysMarkdown(const OptionSectionDoc& section);

// `defaults`: the object the reader starts from (null: no defaults).
template <typename O>
OptionSectionDoc KeysDoc(std::string name, const std::vector<OptionKey<O>>& table, O* defaults) {
  OptionSectionDoc s{std::move(name), {}};
  for (const auto& k : table) {
    // (ostringstream: GCC 12's -Wrestrict misfires on string concatenation here)
    std::ostringstream def, doc;
    if (k.ref && defaults)
      def << '`' << FormatOptionValue(k.ref(*defaults)) << '`';
    else
      def << "—";
    if (!k.scope.empty()) doc << '(' << k.scope << " only) ";
    doc << k.doc;
    s.keys.push_back({k.key, def.str(), k.unit, doc.str()});
  }
  return s;
}

}  // namespace drape
