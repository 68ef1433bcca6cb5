#include "cli/config.h"

#include <algorithm>

#include "common/error.h"
#include "common/files.h"
#include "common/yaml.h"

namespace drape::cli {
namespace {

std::vector<const ConfigSectionBase*>& MutableSections() {
  static std::vector<const ConfigSectionBase*> sections;
  return sections;
}

}  // namespace

CLI::Option* AddConfig(CLI::App& app, std::string& path) {
  return app.add_option("--config", path, "research options file, YAML or JSON (docs/options.md)")
      ->type_name("FILE")
      ->check(CLI::Validator(CLI::ExistingFile).description(""));
}

ConfigSectionBase::ConfigSectionBase(std::string name, std::string summary)
    : name_(std::move(name)), summary_(std::move(summary)) {
  MutableSections().push_back(this);
}

const std::vector<const ConfigSectionBase*>& ConfigSections() { return MutableSections(); }

OptionsFile OptionsFile::Parse(const std::string& text, const std::string& label) {
  OptionsFile f;
  f.reader_ = YamlKeyReader(label);
  f.root_ = LoadYaml(text, label);
  if (!f.root_.IsDefined() || f.root_.IsNull()) return f;  // an empty file sets nothing
  std::vector<std::string> names;
  for (const ConfigSectionBase* s : ConfigSections()) names.push_back(s->name());
  std::sort(names.begin(), names.end());
  f.reader_.CheckKeys(f.root_, "", names);
  const YAML::Node& root = f.root_;  // const: looking a key up never adds it
  for (const ConfigSectionBase* s : ConfigSections()) {
    const YAML::Node n = root[s->name()];
    if (n.IsDefined() && !n.IsNull()) s->Check(f.reader_, n);
  }
  return f;
}

OptionsFile OptionsFile::Load(const std::filesystem::path& path) { return Parse(ReadFile(path), path.string()); }

OptionsFile OptionsFile::LoadIfGiven(const std::string& path) { return path.empty() ? OptionsFile() : Load(path); }

YAML::Node OptionsFile::section(const std::string& name) const {
  const YAML::Node& root = root_;
  if (!root.IsDefined() || root.IsNull() || !root[name].IsDefined()) return YAML::Node(YAML::NodeType::Undefined);
  return root[name];
}

std::string OptionsFileMarkdown() {
  std::vector<const ConfigSectionBase*> sections = ConfigSections();
  std::sort(sections.begin(), sections.end(), [](auto* a, auto* b) { return a->name() < b->name(); });
  std::string md;
  for (const ConfigSectionBase* s : sections) {
    md += "<!-- options: " + s->name() + " -->\n### `" + s->name() + "`\n\n" + s->summary() + "\n\n" +
          KeysMarkdown(s->Doc()) + "<!-- /options -->\n\n";
  }
  return md;
}

}  // namespace drape::cli
