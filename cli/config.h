// The options file: research knobs that stay, off the command line. One file serves every
// command (`drape COMMAND --config FILE`, YAML or JSON); its top-level keys are sections,
// each read into a stage's options struct through a key table (common/option_keys.h) as
// strictly as recipes are: an unknown or misspelt section or key, a value of the wrong
// type or out of its struct's Validate() range is an error "FILE:LINE:COL: section.key:
// what". The whole file is checked whichever command reads it, so a misspelling never
// waits for the command that would have used it. docs/options.md lists every section
// (generated from the tables; cli_test checks it).
//
// A command file declares the sections it reads:
//   const ConfigSection<CategoryFitOptions> kCategoryFit("category_fit", "…", {rows…});
// and reads one with kCategoryFit.Read(file, options).
#pragma once

#include <yaml-cpp/yaml.h>

#include <CLI/App.hpp>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "common/option_keys.h"
#include "common/yaml_keys.h"

namespace drape::cli {

// --config FILE on `app`.
CLI::Option* AddConfig(CLI::App& app, std::string& path);

class OptionsFile {
 public:
  OptionsFile() = default;  // no file: every section keeps its defaults
  // Reads and checks the whole file (every section against its table, each struct
  // validated). Throws drape::Error naming FILE:LINE:COL and the key.
  static OptionsFile Load(const std::filesystem::path& path);
  // As Load, from text; `label` names the file in errors.
  static OptionsFile Parse(const std::string& text, const std::string& label);
  // Load(path), or an empty file when `path` is empty (--config not given).
  static OptionsFile LoadIfGiven(const std::string& path);

  // Section `name`'s node (undefined when absent) and the reader for its errors.
  YAML::Node section(const std::string& name) const;
  const YamlKeyReader& reader() const { return reader_; }

 private:
  YamlKeyReader reader_{""};
  YAML::Node root_;
};

// A section, registered by name (the file's checker and the docs find it).
class ConfigSectionBase {
 public:
  ConfigSectionBase(std::string name, std::string summary);
  virtual ~ConfigSectionBase() = default;
  const std::string& name() const { return name_; }
  const std::string& summary() const { return summary_; }
  // Reads `node` into a default struct and validates it (errors at the key).
  virtual void Check(const YamlKeyReader& reader, const YAML::Node& node) const = 0;
  virtual OptionSectionDoc Doc() const = 0;

 private:
  std::string name_, summary_;
};

// Every registered section, by name.
const std::vector<const ConfigSectionBase*>& ConfigSections();

template <typename O>
class ConfigSection : public ConfigSectionBase {
 public:
  ConfigSection(std::string name, std::string summary, std::vector<OptionKey<O>> keys)
      : ConfigSectionBase(std::move(name), std::move(summary)), keys_(std::move(keys)) {}

  // The file's section into `o` (keys absent keep `o`'s values); `o` validated.
  void Read(const OptionsFile& file, O& o) const {
    const YAML::Node n = file.section(name());
    if (!n.IsDefined() || n.IsNull()) return;
    const YamlKeyReader& r = file.reader();
    r.Validate(o, n, name(), r.Keys(n, name(), keys_, o));
  }
  void Check(const YamlKeyReader& reader, const YAML::Node& node) const override {
    O o;
    reader.Validate(o, node, name(), reader.Keys(node, name(), keys_, o));
  }
  OptionSectionDoc Doc() const override {
    O defaults;
    return KeysDoc(name(), keys_, &defaults);
  }

 private:
  std::vector<OptionKey<O>> keys_;
};

// docs/options.md's text: a table per section, generated from the registered tables.
std::string OptionsFileMarkdown();

}  // namespace drape::cli
