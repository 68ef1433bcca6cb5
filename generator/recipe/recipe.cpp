#include "generator/recipe/recipe.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <variant>

#include "common/error.h"
#include "common/field_error.h"
#include "common/files.h"
#include "common/yaml.h"
#include "common/yaml_keys.h"
#include "garments/io.h"
#include "generator/recipe/keys.h"

namespace fs = std::filesystem;

namespace drape {

const GarmentSpec* Recipe::FindGarment(const std::string& n) const {
  for (const auto& g : garments)
    if (g.name == n) return &g;
  return nullptr;
}

namespace {

const std::regex kNameRe("[A-Za-z0-9][A-Za-z0-9_-]*");

// Parsing context: the file label and the recipe folder, plus helpers that build
// located errors.
class Parser : public YamlKeyReader {
 public:
  Parser(const std::string& label, fs::path base, bool allow_outside,
         const std::map<std::string, fs::path>* files = nullptr)
      : YamlKeyReader(label), base_(std::move(base)), allow_outside_(allow_outside), files_(files) {}

  static std::string Describe(const YAML::Node& n) { return DescribeYaml(n); }

  std::string Name(const YAML::Node& map, const std::string& key, const std::string& path) const {
    auto s = String(map, key, path);
    if (!s) Fail(map, path, "missing key '" + key + "'");
    if (!std::regex_match(*s, kNameRe))
      Fail(map[key], Sub(path, key), "'" + *s + "' is not a valid name (letters, digits, '_' and '-')");
    return *s;
  }

  std::vector<std::string> Strings(const YAML::Node& n, const std::string& path) const {
    if (!n.IsSequence()) Fail(n, path, "expected a list, got " + Describe(n));
    std::vector<std::string> out;
    for (size_t i = 0; i < n.size(); ++i) {
      if (!n[i].IsScalar())
        Fail(n[i], path + "[" + std::to_string(i) + "]", "expected a string, got " + Describe(n[i]));
      out.push_back(n[i].Scalar());
    }
    return out;
  }

  Vec3 Vector3(const YAML::Node& n, const std::string& path) const {
    if (!n.IsSequence() || n.size() != 3) Fail(n, path, "expected a list of 3 numbers, got " + Describe(n));
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
      try {
        v[i] = n[i].as<double>();
      } catch (const YAML::Exception&) {
        Fail(n[i], path + "[" + std::to_string(i) + "]", "expected a number, got " + Describe(n[i]));
      }
      if (!std::isfinite(v[i])) Fail(n[i], path + "[" + std::to_string(i) + "]", "must be finite");
    }
    return v;
  }

  // A file path relative to the recipe folder; must exist and stay inside the
  // folder unless allow_outside_paths.
  fs::path File(const YAML::Node& map, const std::string& key, const std::string& path) const {
    const auto s = String(map, key, path);
    const std::string p = Sub(path, key);
    if (files_) {
      const auto it = files_->find(*s);
      if (it == files_->end()) Fail(map[key], p, "'" + *s + "' is not among the files carried with the recipe");
      if (!fs::is_regular_file(it->second)) Fail(map[key], p, "file not found: " + it->second.string());
      return it->second;
    }
    const fs::path rel(*s);
    const fs::path full = (rel.is_absolute() ? rel : base_ / rel).lexically_normal();
    const fs::path base = fs::weakly_canonical(base_);
    fs::path canon = fs::weakly_canonical(full);
    const fs::path inside = canon.lexically_relative(base);
    const bool escapes = inside.empty() || *inside.begin() == "..";
    if (escapes && !allow_outside_)
      Fail(map[key], p,
           "'" + *s + "' is outside the recipe's folder " + base.string() +
               " (set allow_outside_paths: true to allow it)");
    if (!fs::is_regular_file(canon)) Fail(map[key], p, "file not found: " + canon.string());
    return canon;
  }

  const fs::path& base() const { return base_; }

 private:
  fs::path base_;
  bool allow_outside_;
  const std::map<std::string, fs::path>* files_;  // path as written → file (a release's copy)
};

Material ParseMaterial(const Parser& P, const std::string& name, const YAML::Node& n, const std::string& path) {
  P.RequireMap(n, path);
  Material m;
  if (auto preset = P.String(n, "preset", path)) {
    const Material* base = FindMaterialPreset(*preset);
    if (!base) {
      std::vector<std::string> names;
      for (const auto& pm : MaterialPresets()) names.push_back(pm.name);
      P.Fail(n["preset"], path + ".preset",
             "unknown material preset '" + *preset + "'" + Suggest(*preset, names) + "; presets: " + JoinNames(names));
    }
    m = *base;
  } else {
    if (!n["stretch_percent"].IsDefined() || !n["friction_deg"].IsDefined())
      P.Fail(n, path, "a custom material needs stretch_percent and friction_deg (or preset: NAME)");
  }
  m.name = name;
  P.Validate(m, n, path, P.Keys(n, path, recipe_keys::MaterialKeys(), m));
  return m;
}

void ParseSimulation(const Parser& P, const YAML::Node& n, HangOptions& h) {
  P.Validate(h, n, "simulation", P.Keys(n, "simulation", recipe_keys::SimulationKeys(), h));
}

void ParseSensing(const Parser& P, const YAML::Node& n, const std::string& path, SensingSpec& s) {
  P.Validate(s.sweep, n, path, P.Keys(n, path, recipe_keys::SensingKeys(), s));
}

void ParseFusion(const Parser& P, const YAML::Node& n, FusionOptions& f) {
  std::vector<SetField> set = P.Keys(n, "fusion", recipe_keys::FusionKeys(), f);
  if (n["box"].IsDefined()) {
    const YAML::Node b = n["box"];
    P.CheckKeys(b, "fusion.box", {"min", "max"});
    if (!b["min"].IsDefined() || !b["max"].IsDefined()) P.Fail(b, "fusion.box", "needs both min and max");
    const Vec3 lo = P.Vector3(b["min"], "fusion.box.min"), hi = P.Vector3(b["max"], "fusion.box.max");
    if (!(lo.array() < hi.array()).all()) P.Fail(b, "fusion.box", "min must be below max on every axis");
    f.box = Eigen::AlignedBox3d(lo, hi);
    set.push_back({&f.box, b, "fusion.box"});
  }
  P.Validate(f, n, "fusion", set);
}

void ParseFeature(const Parser& P, const YAML::Node& n, FeatureOptions& f) {
  P.Validate(f, n, "feature", P.Keys(n, "feature", recipe_keys::FeatureKeys(), f));
}

// A template garment: its template, parameters and preset outline.
void ParseTemplateGarment(const Parser& P, const YAML::Node& n, const std::string& path, GarmentSpec& g,
                          std::vector<SetField> set) {
  const std::string t = *P.String(n, "template", path);
  const TemplateInfo* info = nullptr;
  std::vector<std::string> names;
  for (const auto& ti : Templates()) {
    names.push_back(ti.name);
    if (ti.name == t) info = &ti;
  }
  if (!info)
    P.Fail(n["template"], path + ".template",
           "unknown template '" + t + "'" + Suggest(t, names) + "; templates: " + JoinNames(names));
  g.template_name = t;
  g.category = info->category;
  g.all_anchor_labels = info->anchor_labels;
  if (n["params"].IsDefined()) {
    const YAML::Node pm = n["params"];
    std::vector<std::string> pnames;
    for (const auto& tp : info->parameters) pnames.push_back(tp.name);
    P.CheckKeys(pm, path + ".params", pnames);
    for (auto it = pm.begin(); it != pm.end(); ++it) {
      const std::string k = it->first.Scalar(), kp = path + ".params." + k;
      double& v = g.options.params[k];
      v = P.Number(it->second, kp);
      set.push_back({&v, it->second, kp});
    }
  }
  P.Validate(g.options, n, path, set);
  // The outline of the preset instance: catches bad sizes and parameter
  // combinations (self-intersecting outlines) here rather than mid-build.
  struct ShapeCheck {
    const std::string& t;
    const TemplateOptions& o;
    void Validate() const { MakeTemplateShape(t, o); }
  };
  P.Validate(ShapeCheck{t, g.options}, n, path, set);
  g.name = n["name"].IsDefined() ? P.Name(n, "name", path) : t;
}

// An imported mesh file: loaded once here for its anchor labels.
void ParseImportedGarment(const Parser& P, const YAML::Node& n, const std::string& path, GarmentSpec& g) {
  g.file = P.File(n, "file", path);
  g.file_as_written = n["file"].Scalar();
  if (n["anchors_file"].IsDefined()) {
    g.anchors = P.File(n, "anchors_file", path);
    g.anchors_as_written = n["anchors_file"].Scalar();
  }
  g.category = P.String(n, "category", path).value_or("custom");
  g.name = n["name"].IsDefined() ? P.Name(n, "name", path) : g.file.stem().string();
  if (!std::regex_match(g.name, kNameRe))
    P.Fail(n["file"], path + ".file", "file name '" + g.name + "' is not a valid garment name; add name: NAME");
  ImportOptions io;
  io.unit_scale = g.unit_scale;
  io.category = g.category;
  io.instance = g.name;
  P.Validate(io, n, path, {});  // unit_scale
  try {
    const Garment imported = ImportGarment(g.file, g.anchors, io);
    for (const auto& a : imported.anchors) g.all_anchor_labels.push_back(a.label);
  } catch (const Error& e) {
    P.Fail(n["file"], path + ".file", e.what());
  }
  if (g.all_anchor_labels.empty())
    P.Fail(n, path, "the imported garment has no labelled anchors (give anchors_file: PATH)");
}

// Materials: names from the presets or the recipe's materials section.
void ParseGarmentMaterials(const Parser& P, const YAML::Node& n, const std::string& path, const Recipe& r,
                           GarmentSpec& g) {
  if (!n["materials"].IsDefined()) P.Fail(n, path, "missing key 'materials' (a list of material names)");
  g.materials = P.Strings(n["materials"], path + ".materials");
  if (g.materials.empty()) P.Fail(n["materials"], path + ".materials", "the list is empty");
  std::vector<std::string> known;
  for (const auto& [name, m] : r.materials) known.push_back(name);
  for (size_t i = 0; i < g.materials.size(); ++i) {
    const std::string& m = g.materials[i];
    if (!r.materials.count(m))
      P.Fail(n["materials"][i], path + ".materials[" + std::to_string(i) + "]",
             "unknown material '" + m + "'" + Suggest(m, known) + "; known: " + JoinNames(known));
    if (std::count(g.materials.begin(), g.materials.begin() + i, m))
      P.Fail(n["materials"][i], path + ".materials[" + std::to_string(i) + "]", "material listed twice");
  }
}

// Anchors: `all` (default) or a list of labels the garment has.
void ParseGarmentAnchors(const Parser& P, const YAML::Node& n, const std::string& path, GarmentSpec& g) {
  const YAML::Node a = n["anchors"];
  if (!a.IsDefined() || (a.IsScalar() && a.Scalar() == "all")) {
    g.anchor_labels = g.all_anchor_labels;
  } else {
    if (!a.IsSequence())
      P.Fail(a, path + ".anchors", "expected 'all' or a list of anchor labels, got " + P.Describe(a));
    g.anchor_labels = P.Strings(a, path + ".anchors");
    if (g.anchor_labels.empty()) P.Fail(a, path + ".anchors", "the list is empty");
    for (size_t i = 0; i < g.anchor_labels.size(); ++i) {
      const std::string& l = g.anchor_labels[i];
      const std::string ip = path + ".anchors[" + std::to_string(i) + "]";
      if (std::find(g.all_anchor_labels.begin(), g.all_anchor_labels.end(), l) == g.all_anchor_labels.end())
        P.Fail(a[i], ip,
               "anchor label '" + l + "' does not exist on " +
                   (g.template_name.empty() ? "'" + g.file.filename().string() + "'"
                                            : "template '" + g.template_name + "'") +
                   Suggest(l, g.all_anchor_labels) + "; labels: " + JoinNames(g.all_anchor_labels));
      if (std::count(g.anchor_labels.begin(), g.anchor_labels.begin() + i, l)) P.Fail(a[i], ip, "label listed twice");
    }
  }
}

GarmentSpec ParseGarment(const Parser& P, const YAML::Node& n, const std::string& path, const Recipe& r) {
  GarmentSpec g;
  const std::vector<SetField> set = P.Keys(n, path, recipe_keys::GarmentKeys(), g);
  const bool has_t = n["template"].IsDefined(), has_f = n["file"].IsDefined();
  if (has_t == has_f) P.Fail(n, path, "give exactly one of 'template' or 'file'");
  const std::string kind = has_t ? "templates" : "imports";
  for (const auto& k : recipe_keys::GarmentKeys())
    if (!k.scope.empty() && k.scope != kind && n[k.key].IsDefined())
      P.Fail(P.KeyNode(n, k.key), Parser::Sub(path, k.key),
             has_t ? "applies to imported files only" : "applies to templates only");
  if (has_t)
    ParseTemplateGarment(P, n, path, g, set);
  else
    ParseImportedGarment(P, n, path, g);
  P.Validate(g, n, path, set);
  ParseGarmentMaterials(P, n, path, r, g);
  ParseGarmentAnchors(P, n, path, g);
  return g;
}

std::vector<int> ParseInstances(const Parser& P, const YAML::Node& n, const std::string& path, int count) {
  std::vector<int> out;
  if (!n.IsDefined() || (n.IsScalar() && n.Scalar() == "all")) {
    for (int i = 0; i < count; ++i) out.push_back(i);
    return out;
  }
  if (!n.IsSequence()) P.Fail(n, path, "expected 'all' or a list of instance indices, got " + P.Describe(n));
  for (size_t i = 0; i < n.size(); ++i) {
    const std::string ip = path + "[" + std::to_string(i) + "]";
    long long v;
    try {
      v = n[i].as<long long>();
    } catch (const YAML::Exception&) {
      P.Fail(n[i], ip, "expected an instance index, got " + P.Describe(n[i]));
    }
    if (v < 0 || v >= count)
      P.Fail(n[i], ip,
             "instance " + std::to_string(v) + " out of range (the garment has " + std::to_string(count) +
                 " instances, numbered from 0)");
    if (std::count(out.begin(), out.end(), static_cast<int>(v))) P.Fail(n[i], ip, "instance listed twice");
    out.push_back(static_cast<int>(v));
  }
  if (out.empty()) P.Fail(n, path, "the list is empty");
  std::sort(out.begin(), out.end());
  return out;
}

void ParsePerturbation(const Parser& P, const YAML::Node& n, const std::string& path, Perturbation& pt) {
  std::vector<SetField> set = P.Keys(n, path, recipe_keys::PerturbationKeys(), pt);
  if (n["size_scale"].IsDefined()) {
    const YAML::Node s = n["size_scale"];
    const std::string sp = path + ".size_scale";
    if (s.IsScalar()) {
      pt.size_scale_min = pt.size_scale_max = P.Number(s, sp);
      set.push_back({&pt.size_scale_min, s, sp});
      set.push_back({&pt.size_scale_max, s, sp});
    } else if (s.IsSequence() && s.size() == 2) {
      pt.size_scale_min = P.Number(s[0], sp + "[0]");
      pt.size_scale_max = P.Number(s[1], sp + "[1]");
      set.push_back({&pt.size_scale_min, s[0], sp + "[0]"});
      set.push_back({&pt.size_scale_max, s[1], sp + "[1]"});
    } else {
      P.Fail(s, sp, "expected a number or [min, max], got " + P.Describe(s));
    }
  }
  P.Validate(pt, n, path, set);
}

struct InstanceUse {
  std::string split;
  YAML::Mark mark;
};

// One entry of a split's `garments:` list. `used` records which split each
// instance went to: an instance belongs to one split only.
SplitSelector ParseSelector(const Parser& P, const YAML::Node& e, const std::string& ep, const Recipe& r,
                            const std::string& split, std::map<std::pair<std::string, int>, InstanceUse>& used) {
  SplitSelector sel;
  P.Validate(sel, e, ep, P.Keys(e, ep, recipe_keys::SelectorKeys(), sel));
  const auto gname = P.String(e, "garment", ep);
  if (!gname) P.Fail(e, ep, "missing key 'garment'");
  const GarmentSpec* g = r.FindGarment(*gname);
  if (!g) {
    std::vector<std::string> gn;
    for (const auto& gg : r.garments) gn.push_back(gg.name);
    P.Fail(e["garment"], ep + ".garment",
           "unknown garment '" + *gname + "'" + Suggest(*gname, gn) + "; garments: " + JoinNames(gn));
  }
  sel.garment = g->name;
  sel.instances = ParseInstances(P, e["instances"], ep + ".instances", g->instances);
  if (e["materials"].IsDefined()) {
    sel.materials = P.Strings(e["materials"], ep + ".materials");
    if (sel.materials.empty()) P.Fail(e["materials"], ep + ".materials", "the list is empty");
    for (size_t k = 0; k < sel.materials.size(); ++k)
      if (std::find(g->materials.begin(), g->materials.end(), sel.materials[k]) == g->materials.end())
        P.Fail(e["materials"][k], ep + ".materials[" + std::to_string(k) + "]",
               "garment '" + g->name + "' has no material '" + sel.materials[k] + "'" +
                   Suggest(sel.materials[k], g->materials) + "; its materials: " + JoinNames(g->materials));
  }
  if (e["anchors"].IsDefined() && !(e["anchors"].IsScalar() && e["anchors"].Scalar() == "all")) {
    sel.anchors = P.Strings(e["anchors"], ep + ".anchors");
    if (sel.anchors.empty()) P.Fail(e["anchors"], ep + ".anchors", "the list is empty");
    for (size_t k = 0; k < sel.anchors.size(); ++k)
      if (std::find(g->anchor_labels.begin(), g->anchor_labels.end(), sel.anchors[k]) == g->anchor_labels.end())
        P.Fail(e["anchors"][k], ep + ".anchors[" + std::to_string(k) + "]",
               "anchor label '" + sel.anchors[k] + "' is not among garment '" + g->name + "''s anchors" +
                   Suggest(sel.anchors[k], g->anchor_labels) + "; its anchors: " + JoinNames(g->anchor_labels));
  }
  const YAML::Node inode = e["instances"].IsDefined() ? e["instances"] : e;
  for (int inst : sel.instances) {
    auto [it, fresh] = used.insert({{g->name, inst}, {split, inode.Mark()}});
    if (!fresh)
      P.Fail(inode, ep + ".instances",
             "instance " + std::to_string(inst) + " of '" + g->name + "' is already in split '" + it->second.split +
                 "' (line " + std::to_string(it->second.mark.line + 1) +
                 "); all anchors of one instance stay in one split");
  }
  return sel;
}

// The miss curve's levels: whole millimetres in [0, 0.5] m, strictly ascending.
std::vector<double> ParseMissCurve(const Parser& P, const YAML::Node& n, const std::string& path) {
  if (!n.IsSequence()) P.Fail(n, path, "expected a list of grasp misses in metres, got " + P.Describe(n));
  if (n.size() == 0) P.Fail(n, path, "the list is empty");
  if (n.size() > 20) P.Fail(n, path, "at most 20 levels (each is a test split of its own)");
  std::vector<double> out;
  for (size_t i = 0; i < n.size(); ++i) {
    const std::string ip = path + "[" + std::to_string(i) + "]";
    const double v = P.Number(n[i], ip);
    if (!(v >= 0 && v <= 0.5)) P.Fail(n[i], ip, "must be in [0, 0.5] m");
    if (std::abs(v * 1000 - std::round(v * 1000)) > 1e-6)
      P.Fail(n[i], ip, "must be whole millimetres (it names the split test_miss_<mm>mm)");
    if (!out.empty() && !(v > out.back())) P.Fail(n[i], ip, "levels must be strictly ascending");
    out.push_back(v);
  }
  return out;
}

// The miss curve's splits of `test` (none without a curve): the test split's garments,
// sensing and perturbation, with the grasp `level` from the anchor instead of its miss.
std::vector<SplitSpec> MissCurveSplits(const SplitSpec& test) {
  std::vector<SplitSpec> out;
  for (double level : test.miss_curve) {
    SplitSpec rung = test;
    rung.name = MissCurveSplitName(level);
    rung.miss_curve.clear();
    rung.miss_level = level;
    rung.perturbation.grasp_miss = 0;
    rung.perturbation.grasp_offset = level;
    out.push_back(std::move(rung));
  }
  return out;
}

bool IsLadderSplit(const std::string& name) {
  if (name.rfind("test_", 0) != 0 || name.size() == 5) return false;
  for (char c : name)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

void ParseSplits(const Parser& P, const YAML::Node& n, Recipe& r) {
  std::vector<std::string> names = {"train", "calibration", "test"};
  P.RequireMap(n, "splits");
  // Ladder rungs (test_<rung>) after test, in the recipe's order.
  for (auto it = n.begin(); it != n.end(); ++it)
    if (it->first.IsScalar() && IsLadderSplit(it->first.Scalar())) names.push_back(it->first.Scalar());
  P.CheckKeys(n, "splits", names);
  std::map<std::pair<std::string, int>, InstanceUse> used;
  for (const auto& split : names) {
    const YAML::Node s = n[split];
    if (!s.IsDefined()) continue;
    const std::string path = "splits." + split;
    SplitSpec sp;
    sp.name = split;
    P.Validate(sp, s, path, P.Keys(s, path, recipe_keys::SplitKeys(), sp));
    sp.sensing = P.String(s, "sensing", path).value_or(split == "train" ? "database" : "sensed");
    if (sp.sensing != "database" && sp.sensing != "sensed")
      P.Fail(s["sensing"], path + ".sensing",
             "unknown sensing kind '" + sp.sensing + "'" + Suggest(sp.sensing, {"database", "sensed"}) +
                 "; kinds: database, sensed");
    if (s["perturbation"].IsDefined()) ParsePerturbation(P, s["perturbation"], path + ".perturbation", sp.perturbation);
    if (sp.unperturbed && !sp.perturbation.Any())
      P.Fail(s["unperturbed"], path + ".unperturbed",
             "'unperturbed: true' needs a perturbation: without one every repeat is unperturbed too");
    if (sp.hangs_per_anchor == 1 && sp.hang_variation.Any())
      P.Fail(s["hang_variation"], path + ".hang_variation",
             "a hang variation needs hangs_per_anchor > 1: it varies hangs 1..K−1 (hang 0 is the anchor's own)");
    if (s["miss_curve"].IsDefined()) {
      if (split != "test") P.Fail(s["miss_curve"], path + ".miss_curve", "only the test split has a miss curve");
      sp.miss_curve = ParseMissCurve(P, s["miss_curve"], path + ".miss_curve");
    }
    const YAML::Node gl = s["garments"];
    if (!gl.IsDefined()) P.Fail(s, path, "missing key 'garments' (a list of {garment, instances, ...})");
    if (!gl.IsSequence()) P.Fail(gl, path + ".garments", "expected a list, got " + P.Describe(gl));
    if (gl.size() == 0) P.Fail(gl, path + ".garments", "the list is empty");
    for (size_t i = 0; i < gl.size(); ++i) {
      // A ladder rung may re-use any instance (the database entries themselves).
      std::map<std::pair<std::string, int>, InstanceUse> own;
      sp.selectors.push_back(ParseSelector(P, gl[i], path + ".garments[" + std::to_string(i) + "]", r, split,
                                           IsLadderSplit(split) ? own : used));
    }
    for (const SplitSpec& rung : MissCurveSplits(sp))
      if (n[rung.name].IsDefined())
        P.Fail(Parser::KeyNode(n, rung.name), "splits." + rung.name,
               "this split is also made by splits.test.miss_curve: drop one of them");
    std::vector<SplitSpec> rungs = MissCurveSplits(sp);
    r.splits.push_back(std::move(sp));
    for (SplitSpec& rung : rungs) r.splits.push_back(std::move(rung));
  }
  if (r.splits.empty()) P.Fail(n, "splits", "no split given (train, calibration, test)");
  for (const auto& g : r.garments)
    for (int i = 0; i < g.instances; ++i)
      if (!used.count({g.name, i}))
        r.warnings.push_back("instance " + std::to_string(i) + " of garment '" + g.name + "' is in no split");
}

}  // namespace

// The recipe structs' own ranges (the stages' are in their Validate()).
void GarmentSpec::Validate() const {
  if (instances < 1 || instances > 100000) BadField(instances, "instances", "must be in 1..100000");
}

void Perturbation::Validate() const {
  if (!(grasp_offset >= 0 && grasp_offset <= 0.5)) BadField(grasp_offset, "grasp_offset", "must be in [0, 0.5] m");
  if (!(grasp_miss >= 0 && grasp_miss <= 0.5)) BadField(grasp_miss, "grasp_miss", "must be in [0, 0.5] m");
  if (grasp_miss > 0 && grasp_offset > 0)
    BadField(grasp_miss, "grasp_miss", "not together with grasp_offset (a miss drawn per job, or a fixed distance)");
  if (!(material_jitter >= 0 && material_jitter <= 0.9))
    BadField(material_jitter, "material_jitter", "must be in [0, 0.9]");
  if (!(size_scale_min > 0 && size_scale_min <= 10)) BadField(size_scale_min, "size_scale", "must be in (0, 10]");
  if (!(size_scale_max > 0 && size_scale_max <= 10)) BadField(size_scale_max, "size_scale", "must be in (0, 10]");
  if (size_scale_min > size_scale_max) BadField(size_scale_max, "size_scale", "expected [min, max] with min <= max");
  if (!(gripper_pose_noise >= 0 && gripper_pose_noise <= 45))
    BadField(gripper_pose_noise, "gripper_pose_noise", "must be in [0, 45] degrees");
}

void SplitSelector::Validate() const {
  if (max_anchors < 0 || max_anchors > 100000) BadField(max_anchors, "max_anchors", "must be in 0..100000 (0 = all)");
}

void SplitSpec::Validate() const {
  if (repeats < 1 || repeats > 1000) BadField(repeats, "repeats", "must be in 1..1000");
  if (hangs_per_anchor < 1 || hangs_per_anchor > 1000)
    BadField(hangs_per_anchor, "hangs_per_anchor", "must be in 1..1000");
  const HangVariation& v = hang_variation;
  if (!(v.grasp_miss >= 0 && v.grasp_miss <= 0.5)) BadField(v.grasp_miss, "grasp_miss", "must be in [0, 0.5] m");
  if (!(v.material_jitter >= 0 && v.material_jitter <= 0.9))
    BadField(v.material_jitter, "material_jitter", "must be in [0, 0.9]");
  if (!(v.pickup_spin >= 0 && v.pickup_spin <= 20)) BadField(v.pickup_spin, "pickup_spin", "must be in [0, 20] rad/s");
}

std::string MissCurveSplitName(double miss) { return "test_miss_" + std::to_string(std::lround(miss * 1000)) + "mm"; }

SensingSpec DatabaseSensingDefaults() {
  SensingSpec s;
  s.sweep.kinect.noise = false;
  return s;
}

namespace {

// name, version (semantic) and seed.
void ParseIdentity(const Parser& P, const YAML::Node& root, Recipe& r) {
  r.name = P.Name(root, "name", "");
  const auto version = P.String(root, "version", "");
  if (!version) P.Fail(root, "version", "missing key 'version' (MAJOR.MINOR.PATCH)");
  if (!std::regex_match(*version, std::regex("(0|[1-9][0-9]*)\\.(0|[1-9][0-9]*)\\.(0|[1-9][0-9]*)")))
    P.Fail(root["version"], "version", "'" + *version + "' is not a semantic version MAJOR.MINOR.PATCH");
  r.version = *version;
  if (!root["seed"].IsDefined()) P.Fail(root, "seed", "missing key 'seed' (a non-negative integer)");
  const YAML::Node s = root["seed"];
  try {
    r.seed = s.as<uint64_t>();
    if (!s.IsScalar() || s.Scalar().empty() || s.Scalar()[0] == '-') throw YAML::Exception(s.Mark(), "");
  } catch (const YAML::Exception&) {
    P.Fail(s, "seed", "expected a non-negative integer, got " + P.Describe(s));
  }
}

// Materials: every preset by name, plus the recipe's own.
void ParseMaterials(const Parser& P, const YAML::Node& root, Recipe& r) {
  for (const auto& m : MaterialPresets()) r.materials[m.name] = m;
  if (!root["materials"].IsDefined()) return;
  const YAML::Node ms = root["materials"];
  P.RequireMap(ms, "materials");
  for (auto it = ms.begin(); it != ms.end(); ++it) {
    const std::string name = it->first.Scalar();
    const std::string path = "materials." + name;
    if (!std::regex_match(name, kNameRe)) P.Fail(it->first, path, "not a valid name (letters, digits, '_' and '-')");
    if (FindMaterialPreset(name))
      P.Fail(it->first, path,
             "'" + name + "' is a preset name; give your material another name (preset: " + name + ")");
    r.materials[name] = ParseMaterial(P, name, it->second, path);
  }
}

// Sensing: database defaults to noise off, sensed to noise on; sensed inherits every
// other key from database.
void ParseSensingKinds(const Parser& P, const YAML::Node& root, Recipe& r) {
  const YAML::Node s = root["sensing"];
  if (s.IsDefined()) P.CheckKeys(s, "sensing", {"database", "sensed"});
  SensingSpec db = DatabaseSensingDefaults();
  if (s.IsDefined() && s["database"].IsDefined()) ParseSensing(P, s["database"], "sensing.database", db);
  SensingSpec sensed = db;
  sensed.sweep.kinect.noise = true;
  if (s.IsDefined() && s["sensed"].IsDefined()) ParseSensing(P, s["sensed"], "sensing.sensed", sensed);
  if (!s.IsDefined() || !s["database"].IsDefined()) db.sweep.Validate();
  if (!s.IsDefined() || !s["sensed"].IsDefined()) sensed.sweep.Validate();
  r.sensing["database"] = db;
  r.sensing["sensed"] = sensed;
}

void ParseGarments(const Parser& P, const YAML::Node& root, Recipe& r) {
  const YAML::Node gl = root["garments"];
  if (!gl.IsDefined()) P.Fail(root, "garments", "missing key 'garments' (a list of garments)");
  if (!gl.IsSequence()) P.Fail(gl, "garments", "expected a list, got " + P.Describe(gl));
  if (gl.size() == 0) P.Fail(gl, "garments", "the garment list is empty");
  for (size_t i = 0; i < gl.size(); ++i) {
    const std::string path = "garments[" + std::to_string(i) + "]";
    GarmentSpec g = ParseGarment(P, gl[i], path, r);
    if (r.FindGarment(g.name))
      P.Fail(gl[i], path, "garment name '" + g.name + "' used twice; give one of them name: OTHER");
    r.garments.push_back(std::move(g));
  }
}

// No splits: every instance is in train (the database).
SplitSpec EverythingInTrain(const Recipe& r) {
  SplitSpec sp;
  sp.name = "train";
  sp.sensing = "database";
  for (const auto& g : r.garments) {
    SplitSelector sel;
    sel.garment = g.name;
    for (int i = 0; i < g.instances; ++i) sel.instances.push_back(i);
    sp.selectors.push_back(sel);
  }
  return sp;
}

}  // namespace

Recipe ParseRecipe(const std::string& text, const std::string& file_label, const fs::path& base_dir,
                   const std::map<std::string, fs::path>* files) {
  const YAML::Node root = LoadYaml(text, file_label);  // const: lookups must not insert keys
  Recipe r;
  r.file_label = file_label;
  r.text = text;
  Parser P0(file_label, base_dir, false);
  if (!root.IsMap()) P0.Fail(root, "(top level)", "a recipe is a mapping of keys (name, version, seed, garments, ...)");
  P0.Keys(root, "", recipe_keys::TopKeys(), r);  // description, license, allow_outside_paths
  const Parser P(file_label, base_dir, r.allow_outside_paths, files);

  ParseIdentity(P, root, r);
  ParseMaterials(P, root, r);
  if (root["simulation"].IsDefined()) ParseSimulation(P, root["simulation"], r.hang);
  ParseSensingKinds(P, root, r);
  if (root["fusion"].IsDefined()) ParseFusion(P, root["fusion"], r.fusion);
  if (root["feature"].IsDefined()) ParseFeature(P, root["feature"], r.feature);
  ParseGarments(P, root, r);
  if (root["splits"].IsDefined())
    ParseSplits(P, root["splits"], r);
  else
    r.splits.push_back(EverythingInTrain(r));
  return r;
}

Recipe LoadRecipe(const fs::path& path) {
  if (!fs::is_regular_file(path)) throw Error(path.string() + ": recipe not found");
  const std::string text = ReadFile(path);
  Recipe r = ParseRecipe(text, path.string(), fs::absolute(path).parent_path());
  r.path = path;
  return r;
}

}  // namespace drape
