// Strict YAML (or JSON) reading into options structs through key tables
// (common/option_keys.h): an unknown or misspelt key is an error with a suggestion, the
// scalar keys are read into the struct, and a Validate() FieldError is mapped back to the
// key that set the field. Every error is a drape::Error "LABEL:LINE:COL: key.path: what"
// (1-based). Library drape_yaml_keys (yaml-cpp).
#pragma once

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "common/field_error.h"
#include "common/option_keys.h"

namespace drape {

// A field of an options struct and the key that set it (for Validate).
struct SetField {
  const void* field;
  YAML::Node node;
  std::string path;
};

// Located errors and typed, strict reads over the nodes of one file.
class YamlKeyReader {
 public:
  explicit YamlKeyReader(std::string label) : label_(std::move(label)) {}

  const std::string& label() const { return label_; }

  [[noreturn]] void Fail(const YAML::Mark& m, const std::string& path, const std::string& what) const;
  [[noreturn]] void Fail(const YAML::Node& n, const std::string& path, const std::string& what) const {
    Fail(n.Mark(), path, what);
  }

  void RequireMap(const YAML::Node& n, const std::string& path) const;
  // Every key of `n` must be in `known`; a misspelt one gets a suggestion; none twice.
  void CheckKeys(const YAML::Node& n, const std::string& path, const std::vector<std::string>& known) const;

  static std::string Sub(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }
  // The key node itself (for its mark), or a null node.
  static YAML::Node KeyNode(const YAML::Node& map, const std::string& key);

  // Scalars. Only the type is checked here (a finite number, an integer that fits,
  // true/false, a string); ranges are the Options structs' Validate().
  std::optional<double> Double(const YAML::Node& map, const std::string& key, const std::string& path) const;
  double Number(const YAML::Node& n, const std::string& path) const;
  std::optional<std::string> String(const YAML::Node& map, const std::string& key, const std::string& path) const;
  void Bool(const YAML::Node& map, const std::string& key, const std::string& path, bool& out) const;
  void Read(const YAML::Node& map, const std::string& key, const std::string& path, double& out) const;
  void Read(const YAML::Node& map, const std::string& key, const std::string& path, int& out) const;
  void Read(const YAML::Node& map, const std::string& key, const std::string& path, std::string& out) const;
  void Read(const YAML::Node& map, const std::string& key, const std::string& path, bool& out) const;

  // Runs an options struct's Validate(). A FieldError for a field that a key set is
  // reported at that key; any other error at the section.
  template <typename Options>
  void Validate(const Options& o, const YAML::Node& section, const std::string& section_path,
                const std::vector<SetField>& set) const {
    try {
      o.Validate();
    } catch (const FieldError& e) {
      for (const auto& f : set)
        if (f.field == e.field()) Fail(f.node, f.path, e.reason());
      Fail(section, section_path, e.what());
    } catch (const Error& e) {
      Fail(section, section_path, e.what());
    }
  }

  // Checks `n`'s keys against `table`, reads the scalar keys present into `o` and
  // returns where each field came from (for Validate).
  template <typename O>
  std::vector<SetField> Keys(const YAML::Node& n, const std::string& path, const std::vector<OptionKey<O>>& table,
                             O& o) const {
    std::vector<std::string> here;                         // keys of this mapping, in table order
    std::vector<std::pair<std::string, std::string>> sub;  // (sub-map, key) of "a.b" keys
    for (const auto& k : table) {
      const size_t dot = k.key.find('.');
      const std::string head = k.key.substr(0, dot);
      if (std::find(here.begin(), here.end(), head) == here.end()) here.push_back(head);
      if (dot != std::string::npos) sub.emplace_back(head, k.key.substr(dot + 1));
    }
    CheckKeys(n, path, here);
    for (const auto& head : here) {
      std::vector<std::string> known;
      for (const auto& [h, k] : sub)
        if (h == head) known.push_back(k);
      if (!known.empty() && n[head].IsDefined()) CheckKeys(n[head], Sub(path, head), known);
    }
    std::vector<SetField> set;
    for (const auto& k : table) {
      if (!k.ref) continue;
      const size_t dot = k.key.find('.');
      const YAML::Node map = dot == std::string::npos ? n : n[k.key.substr(0, dot)];
      const std::string leaf = dot == std::string::npos ? k.key : k.key.substr(dot + 1);
      const std::string map_path = dot == std::string::npos ? path : Sub(path, k.key.substr(0, dot));
      if (!map.IsDefined() || !map[leaf].IsDefined()) continue;
      const OptionRef ref = k.ref(o);
      std::visit([&](auto* field) { Read(map, leaf, map_path, *field); }, ref);
      set.push_back({std::visit([](auto* field) -> const void* { return field; }, ref), map[leaf], Sub(path, k.key)});
    }
    return set;
  }

 private:
  std::string label_;
};

}  // namespace drape
