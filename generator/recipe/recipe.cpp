#include "generator/recipe/recipe.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <regex>
#include <set>
#include <sstream>

#include "common/error.h"
#include "common/files.h"
#include "garments/io.h"

namespace fs = std::filesystem;

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

const GarmentSpec* Recipe::FindGarment(const std::string& n) const {
  for (const auto& g : garments)
    if (g.name == n) return &g;
  return nullptr;
}

namespace {

// " (did you mean 'x'?)" when a candidate is close enough to be a plausible typo.
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

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

const std::regex kNameRe("[A-Za-z0-9][A-Za-z0-9_-]*");

// Parsing context: the file label and the recipe folder, plus helpers that build
// located errors.
class Parser {
 public:
  Parser(const std::string& label, fs::path base, bool allow_outside,
         const std::map<std::string, fs::path>* files = nullptr)
      : label_(label), base_(std::move(base)), allow_outside_(allow_outside), files_(files) {}

  [[noreturn]] void Fail(const YAML::Mark& m, const std::string& path, const std::string& what) const {
    std::ostringstream os;
    os << label_ << ":" << (m.is_null() ? 0 : m.line + 1) << ":" << (m.is_null() ? 0 : m.column + 1)
       << ": " << path << ": " << what;
    throw Error(os.str());
  }
  [[noreturn]] void Fail(const YAML::Node& n, const std::string& path, const std::string& what) const {
    Fail(n.Mark(), path, what);
  }

  static std::string Describe(const YAML::Node& n) {
    if (!n.IsDefined() || n.IsNull()) return "nothing";
    if (n.IsMap()) return "a mapping";
    if (n.IsSequence()) return "a list";
    return "'" + n.Scalar() + "'";
  }

  void RequireMap(const YAML::Node& n, const std::string& path) const {
    if (!n.IsMap()) Fail(n, path, "expected a mapping, got " + Describe(n));
  }

  // Every key of `n` must be in `known`; a misspelt one gets a suggestion.
  void CheckKeys(const YAML::Node& n, const std::string& path, const std::vector<std::string>& known) const {
    RequireMap(n, path);
    std::set<std::string> seen;
    for (auto it = n.begin(); it != n.end(); ++it) {
      const YAML::Node& k = it->first;
      if (!k.IsScalar()) Fail(k, path, "keys must be plain names");
      const std::string key = k.Scalar();
      const std::string kp = path.empty() ? key : path + "." + key;
      if (std::find(known.begin(), known.end(), key) == known.end())
        Fail(k, kp, "unknown key" + Suggest(key, known) + "; known keys here: " + Join(known));
      if (!seen.insert(key).second) Fail(k, kp, "key given twice");
    }
  }

  static std::string Sub(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

  // The key node itself (for its mark), or a null node.
  static YAML::Node KeyNode(const YAML::Node& map, const std::string& key) {
    for (auto it = map.begin(); it != map.end(); ++it)
      if (it->first.Scalar() == key) return it->first;
    return YAML::Node();
  }

  std::optional<double> Double(const YAML::Node& map, const std::string& key, const std::string& path,
                               double lo, double hi, bool lo_open = false) const {
    const YAML::Node n = map[key];
    if (!n.IsDefined()) return std::nullopt;
    const std::string p = Sub(path, key);
    if (!n.IsScalar()) Fail(n, p, "expected a number, got " + Describe(n));
    double v;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      Fail(n, p, "expected a number, got " + Describe(n));
    }
    if (!std::isfinite(v)) Fail(n, p, "must be finite");
    if ((lo_open ? v <= lo : v < lo) || v > hi) {
      std::ostringstream os;
      os << "out of range: " << n.Scalar() << " (allowed " << (lo_open ? "(" : "[") << lo << ", " << hi << "])";
      Fail(n, p, os.str());
    }
    return v;
  }
  void DoubleTo(const YAML::Node& map, const std::string& key, const std::string& path, double& out,
                double lo, double hi, bool lo_open = false) const {
    if (auto v = Double(map, key, path, lo, hi, lo_open)) out = *v;
  }

  std::optional<long long> Int(const YAML::Node& map, const std::string& key, const std::string& path,
                               long long lo, long long hi) const {
    const YAML::Node n = map[key];
    if (!n.IsDefined()) return std::nullopt;
    const std::string p = Sub(path, key);
    if (!n.IsScalar()) Fail(n, p, "expected an integer, got " + Describe(n));
    long long v;
    try {
      v = n.as<long long>();
    } catch (const YAML::Exception&) {
      Fail(n, p, "expected an integer, got " + Describe(n));
    }
    if (v < lo || v > hi) {
      std::ostringstream os;
      os << "out of range: " << v << " (allowed " << lo << ".." << hi << ")";
      Fail(n, p, os.str());
    }
    return v;
  }
  void IntTo(const YAML::Node& map, const std::string& key, const std::string& path, int& out, long long lo,
             long long hi) const {
    if (auto v = Int(map, key, path, lo, hi)) out = static_cast<int>(*v);
  }

  void Bool(const YAML::Node& map, const std::string& key, const std::string& path, bool& out) const {
    const YAML::Node n = map[key];
    if (!n.IsDefined()) return;
    const std::string p = Sub(path, key);
    const std::string s = n.IsScalar() ? n.Scalar() : "";
    if (s == "true") out = true;
    else if (s == "false") out = false;
    else Fail(n, p, "expected true or false, got " + Describe(n));
  }

  std::optional<std::string> String(const YAML::Node& map, const std::string& key, const std::string& path) const {
    const YAML::Node n = map[key];
    if (!n.IsDefined()) return std::nullopt;
    if (!n.IsScalar()) Fail(n, Sub(path, key), "expected a string, got " + Describe(n));
    return n.Scalar();
  }

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
      if (!n[i].IsScalar()) Fail(n[i], path + "[" + std::to_string(i) + "]", "expected a string, got " + Describe(n[i]));
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
    const fs::path canon = fs::weakly_canonical(full);
    const fs::path inside = canon.lexically_relative(base);
    const bool escapes = inside.empty() || *inside.begin() == "..";
    if (escapes && !allow_outside_)
      Fail(map[key], p,
           "'" + *s + "' is outside the recipe's folder " + base.string() +
               " (set allow_outside_paths: true to allow it)");
    if (!fs::is_regular_file(canon)) Fail(map[key], p, "file not found: " + canon.string());
    return canon;
  }

  // Runs an options struct's Validate(); its message names a field, which we map
  // back to the recipe key that set it (fields: option field name → key node, key path).
  struct FieldKey {
    std::string field;
    YAML::Node node;
    std::string path;
  };
  template <typename Options>
  void Validate(const Options& o, const YAML::Node& section, const std::string& section_path,
                const std::vector<FieldKey>& fields) const {
    try {
      o.Validate();
    } catch (const Error& e) {
      const std::string msg = e.what();
      const FieldKey* best = nullptr;
      for (const auto& f : fields)
        if (f.node.IsDefined() && msg.find(f.field) != std::string::npos &&
            (!best || f.field.size() > best->field.size()))
          best = &f;
      if (best) Fail(best->node, best->path, msg);
      Fail(section, section_path, msg);
    }
  }

  const std::string& label() const { return label_; }
  const fs::path& base() const { return base_; }

 private:
  std::string label_;
  fs::path base_;
  bool allow_outside_;
  const std::map<std::string, fs::path>* files_;  // path as written → file (a release's copy)
};

// Option field names, for mapping a Validate() message to the recipe key.
std::vector<Parser::FieldKey> Fields(const YAML::Node& map, const std::string& path,
                                     const std::vector<std::pair<std::string, std::string>>& key_to_field) {
  std::vector<Parser::FieldKey> out;
  if (!map.IsMap()) return out;
  for (const auto& [key, field] : key_to_field) {
    std::string sub_key = key, rest;
    YAML::Node n = map;
    std::string p = path;
    // "settle.distance" style keys walk into sub-maps.
    std::stringstream ss(key);
    std::string part;
    bool ok = true;
    while (std::getline(ss, part, '.')) {
      const YAML::Node cur = n;  // const: lookups must not insert keys
      if (!cur.IsMap() || !cur[part].IsDefined()) {
        ok = false;
        break;
      }
      n.reset(cur[part]);  // (operator= would assign into the map)
      p = Parser::Sub(p, part);
    }
    if (ok) out.push_back({field, n, p});
  }
  return out;
}

const std::vector<std::string> kTopKeys = {
    "name",       "version",   "seed",   "description", "license", "allow_outside_paths", "materials",
    "garments",   "simulation", "sensing", "fusion",     "feature", "splits"};

Material ParseMaterial(const Parser& P, const std::string& name, const YAML::Node& n, const std::string& path) {
  P.CheckKeys(n, path, {"preset", "stretch_percent", "friction_deg", "area_density", "bending"});
  Material m;
  if (auto preset = P.String(n, "preset", path)) {
    const Material* base = FindMaterialPreset(*preset);
    if (!base) {
      std::vector<std::string> names;
      for (const auto& pm : MaterialPresets()) names.push_back(pm.name);
      P.Fail(n["preset"], path + ".preset", "unknown material preset '" + *preset + "'" + Suggest(*preset, names) +
                                                "; presets: " + Join(names));
    }
    m = *base;
  } else {
    if (!n["stretch_percent"].IsDefined() || !n["friction_deg"].IsDefined())
      P.Fail(n, path, "a custom material needs stretch_percent and friction_deg (or preset: NAME)");
  }
  m.name = name;
  P.DoubleTo(n, "stretch_percent", path, m.stretch_percent, 0, 100, true);
  P.DoubleTo(n, "friction_deg", path, m.friction_deg, 0, 90);
  P.DoubleTo(n, "area_density", path, m.area_density, 0, 10, true);
  P.DoubleTo(n, "bending", path, m.bending_stiffness, 0, 1e6);
  P.Validate(m, n, path,
             Fields(n, path, {{"stretch_percent", "stretch_percent"}, {"friction_deg", "friction_deg"},
                              {"area_density", "area_density"}, {"bending", "bending"}}));
  return m;
}

void ParseSimulation(const Parser& P, const YAML::Node& n, HangOptions& h) {
  const std::string path = "simulation";
  P.CheckKeys(n, path, {"time_step", "solver_iterations", "damping", "self_collision", "layer_thickness", "settle",
                        "min_time", "time_cap", "jaw_width", "equilibrium"});
  P.DoubleTo(n, "time_step", path, h.time_step, 0, 0.1, true);
  P.IntTo(n, "solver_iterations", path, h.solver_iterations, 1, 1000);
  P.DoubleTo(n, "layer_thickness", path, h.layer_thickness, 0, 0.1);
  P.DoubleTo(n, "min_time", path, h.min_time, 0, 3600);
  P.DoubleTo(n, "damping", path, h.damping, 0, 1);
  P.Bool(n, "self_collision", path, h.self_collision);
  if (n["settle"].IsDefined()) {
    const YAML::Node s = n["settle"];
    P.CheckKeys(s, "simulation.settle", {"distance", "window"});
    P.DoubleTo(s, "distance", "simulation.settle", h.settle_distance, 0, 1, true);
    P.DoubleTo(s, "window", "simulation.settle", h.settle_window, 0, 100, true);
  }
  P.DoubleTo(n, "time_cap", path, h.time_cap, 0, 3600, true);
  P.DoubleTo(n, "jaw_width", path, h.jaw_width, 0, 1);
  P.Bool(n, "equilibrium", path, h.equilibrium_solve);
  P.Validate(h, n, path,
             Fields(n, path,
                    {{"time_step", "time_step"}, {"solver_iterations", "solver_iterations"}, {"damping", "damping"},
                     {"self_collision", "self_collision"}, {"layer_thickness", "layer_thickness"},
                     {"min_time", "min_time"}, {"settle.distance", "settle_distance"},
                     {"settle.window", "settle_window"}, {"time_cap", "time_cap"}, {"jaw_width", "jaw_width"},
                     {"equilibrium", "equilibrium_solve"}}));
}

const std::vector<std::string> kSensingKeys = {"frames", "degrees",  "back_and_forth", "noise",
                                               "keep_frames", "scene", "camera"};

void ParseSensing(const Parser& P, const YAML::Node& n, const std::string& path, SensingSpec& s) {
  P.CheckKeys(n, path, kSensingKeys);
  SweepOptions& o = s.sweep;
  P.IntTo(n, "frames", path, o.frames, 1, 100000);
  P.DoubleTo(n, "degrees", path, o.degrees, 0, 3600, true);
  P.Bool(n, "back_and_forth", path, o.back_and_forth);
  P.Bool(n, "noise", path, o.kinect.noise);
  P.Bool(n, "keep_frames", path, s.keep_frames);
  P.Bool(n, "scene", path, o.scene);
  if (n["camera"].IsDefined()) {
    const YAML::Node c = n["camera"];
    const std::string cp = path + ".camera";
    P.CheckKeys(c, cp, {"height", "distance", "gripper_height", "look_at_height", "image_width", "image_height",
                        "fx", "fy", "cx", "cy", "min_range", "max_range"});
    P.DoubleTo(c, "gripper_height", cp, o.gripper_height, -10, 10);
    P.DoubleTo(c, "look_at_height", cp, o.look_at_height, -10, 10);
    P.DoubleTo(c, "height", cp, o.camera_height, -10, 10);
    P.DoubleTo(c, "distance", cp, o.camera_distance, 0, 20, true);
    P.IntTo(c, "image_width", cp, o.kinect.intrinsics.width, 8, 8192);
    P.IntTo(c, "image_height", cp, o.kinect.intrinsics.height, 8, 8192);
    P.DoubleTo(c, "fx", cp, o.kinect.intrinsics.fx, 0, 1e5, true);
    P.DoubleTo(c, "fy", cp, o.kinect.intrinsics.fy, 0, 1e5, true);
    P.DoubleTo(c, "cx", cp, o.kinect.intrinsics.cx, -1e5, 1e5);
    P.DoubleTo(c, "cy", cp, o.kinect.intrinsics.cy, -1e5, 1e5);
    P.DoubleTo(c, "min_range", cp, o.kinect.min_range, 0, 100);
    P.DoubleTo(c, "max_range", cp, o.kinect.max_range, 0, 100, true);
  }
  auto fields = Fields(n, path,
                       {{"frames", "frames"}, {"degrees", "degrees"}, {"back_and_forth", "back_and_forth"},
                        {"noise", "noise"}, {"scene", "scene"}, {"camera.height", "camera_height"},
                        {"camera.distance", "camera_distance"}, {"camera.gripper_height", "gripper_height"},
                        {"camera.look_at_height", "look_at_height"}, {"camera.image_width", "width"},
                        {"camera.image_height", "height"}, {"camera.fx", "fx"}, {"camera.fy", "fy"},
                        {"camera.cx", "cx"}, {"camera.cy", "cy"}, {"camera.min_range", "min_range"},
                        {"camera.max_range", "max_range"}});
  P.Validate(o, n, path, fields);
}

void ParseFusion(const Parser& P, const YAML::Node& n, FusionOptions& f) {
  const std::string path = "fusion";
  P.CheckKeys(n, path, {"voxels_per_metre", "truncation", "box", "pose_noise_degrees", "frames_stride",
                        "carve_min_views"});
  P.DoubleTo(n, "voxels_per_metre", path, f.voxels_per_metre, 0, 5000, true);
  P.DoubleTo(n, "truncation", path, f.truncation, 0, 1);
  P.DoubleTo(n, "pose_noise_degrees", path, f.pose_noise_degrees, 0, 45);
  P.IntTo(n, "frames_stride", path, f.frames_stride, 1, 100000);
  P.IntTo(n, "carve_min_views", path, f.carve_min_views, 1, 100000);
  if (n["box"].IsDefined()) {
    const YAML::Node b = n["box"];
    P.CheckKeys(b, "fusion.box", {"min", "max"});
    if (!b["min"].IsDefined() || !b["max"].IsDefined()) P.Fail(b, "fusion.box", "needs both min and max");
    const Vec3 lo = P.Vector3(b["min"], "fusion.box.min"), hi = P.Vector3(b["max"], "fusion.box.max");
    if (!(lo.array() < hi.array()).all()) P.Fail(b, "fusion.box", "min must be below max on every axis");
    f.box = Eigen::AlignedBox3d(lo, hi);
  }
  P.Validate(f, n, path,
             Fields(n, path, {{"voxels_per_metre", "voxels_per_metre"}, {"truncation", "truncation"}, {"box", "box"},
                              {"pose_noise_degrees", "pose_noise_degrees"}, {"frames_stride", "frames_stride"},
                              {"carve_min_views", "carve_min_views"}}));
}

void ParseFeature(const Parser& P, const YAML::Node& n, FeatureOptions& f) {
  const std::string path = "feature";
  P.CheckKeys(n, path, {"layers", "rings", "sectors"});
  P.IntTo(n, "layers", path, f.layers, 1, 1024);
  P.IntTo(n, "rings", path, f.rings, 1, 1024);
  P.IntTo(n, "sectors", path, f.sectors, 1, 1024);
  P.Validate(f, n, path, Fields(n, path, {{"layers", "layers"}, {"rings", "rings"}, {"sectors", "sectors"}}));
}

const std::vector<std::string> kGarmentKeys = {"name",   "template",  "file",         "anchors_file", "unit_scale",
                                               "category", "size",    "params",       "instances",    "edge_length",
                                               "layer_gap", "perturbation", "materials", "anchors"};

GarmentSpec ParseGarment(const Parser& P, const YAML::Node& n, const std::string& path, const Recipe& r) {
  P.CheckKeys(n, path, kGarmentKeys);
  GarmentSpec g;
  const bool has_t = n["template"].IsDefined(), has_f = n["file"].IsDefined();
  if (has_t == has_f) P.Fail(n, path, "give exactly one of 'template' or 'file'");
  if (has_t) {
    const std::string t = *P.String(n, "template", path);
    const TemplateInfo* info = nullptr;
    std::vector<std::string> names;
    for (const auto& ti : Templates()) {
      names.push_back(ti.name);
      if (ti.name == t) info = &ti;
    }
    if (!info)
      P.Fail(n["template"], path + ".template",
             "unknown template '" + t + "'" + Suggest(t, names) + "; templates: " + Join(names));
    for (const char* k : {"anchors_file", "unit_scale", "category"})
      if (n[k].IsDefined()) P.Fail(P.KeyNode(n, k), Parser::Sub(path, k), "applies to imported files only");
    g.template_name = t;
    g.category = info->category;
    g.all_anchor_labels = info->anchor_labels;
    if (auto s = P.String(n, "size", path)) g.options.size = *s;
    P.DoubleTo(n, "edge_length", path, g.options.edge_length, 0, 1, true);
    P.DoubleTo(n, "layer_gap", path, g.options.layer_gap, 0, 0.5);
    P.DoubleTo(n, "perturbation", path, g.options.perturbation, 0, 1);
    if (n["params"].IsDefined()) {
      const YAML::Node pm = n["params"];
      std::vector<std::string> pnames;
      for (const auto& tp : info->parameters) pnames.push_back(tp.name);
      P.CheckKeys(pm, path + ".params", pnames);
      for (auto it = pm.begin(); it != pm.end(); ++it) {
        const std::string k = it->first.Scalar();
        g.options.params[k] = *P.Double(pm, k, path + ".params", -1e6, 1e6);
      }
    }
    auto fields = Fields(n, path,
                         {{"size", "size"}, {"edge_length", "edge_length"}, {"layer_gap", "layer_gap"},
                          {"perturbation", "perturbation"}, {"params", "params"}});
    // A parameter name in the message points at that parameter.
    if (n["params"].IsDefined() && n["params"].IsMap())
      for (auto it = n["params"].begin(); it != n["params"].end(); ++it)
        fields.push_back({it->first.Scalar(), it->first, path + ".params." + it->first.Scalar()});
    P.Validate(g.options, n, path, fields);
    // The outline of the preset instance: catches bad sizes and parameter
    // combinations (self-intersecting outlines) here rather than mid-build.
    struct ShapeCheck {
      const std::string& t;
      const TemplateOptions& o;
      void Validate() const { MakeTemplateShape(t, o); }
    };
    P.Validate(ShapeCheck{t, g.options}, n, path, fields);
    g.name = n["name"].IsDefined() ? P.Name(n, "name", path) : t;
  } else {
    for (const char* k : {"size", "params", "edge_length", "layer_gap", "perturbation"})
      if (n[k].IsDefined()) P.Fail(P.KeyNode(n, k), Parser::Sub(path, k), "applies to templates only");
    g.file = P.File(n, "file", path);
    g.file_as_written = n["file"].Scalar();
    if (n["anchors_file"].IsDefined()) {
      g.anchors = P.File(n, "anchors_file", path);
      g.anchors_as_written = n["anchors_file"].Scalar();
    }
    P.DoubleTo(n, "unit_scale", path, g.unit_scale, 0, 1e6, true);
    g.category = P.String(n, "category", path).value_or("custom");
    g.name = n["name"].IsDefined() ? P.Name(n, "name", path) : g.file.stem().string();
    if (!std::regex_match(g.name, kNameRe))
      P.Fail(n["file"], path + ".file", "file name '" + g.name + "' is not a valid garment name; add name: NAME");
    ImportOptions io;
    io.unit_scale = g.unit_scale;
    io.category = g.category;
    io.instance = g.name;
    try {
      const Garment imported = ImportGarment(g.file, g.anchors, io);
      for (const auto& a : imported.anchors) g.all_anchor_labels.push_back(a.label);
    } catch (const Error& e) {
      P.Fail(n["file"], path + ".file", e.what());
    }
    if (g.all_anchor_labels.empty())
      P.Fail(n, path, "the imported garment has no labelled anchors (give anchors_file: PATH)");
  }
  P.IntTo(n, "instances", path, g.instances, 1, 100000);

  // Materials: names from the presets or the recipe's materials section.
  if (!n["materials"].IsDefined()) P.Fail(n, path, "missing key 'materials' (a list of material names)");
  g.materials = P.Strings(n["materials"], path + ".materials");
  if (g.materials.empty()) P.Fail(n["materials"], path + ".materials", "the list is empty");
  std::vector<std::string> known;
  for (const auto& [name, m] : r.materials) known.push_back(name);
  for (size_t i = 0; i < g.materials.size(); ++i) {
    const std::string& m = g.materials[i];
    if (!r.materials.count(m))
      P.Fail(n["materials"][i], path + ".materials[" + std::to_string(i) + "]",
             "unknown material '" + m + "'" + Suggest(m, known) + "; known: " + Join(known));
    if (std::count(g.materials.begin(), g.materials.begin() + i, m))
      P.Fail(n["materials"][i], path + ".materials[" + std::to_string(i) + "]", "material listed twice");
  }

  // Anchors: `all` (default) or a list of labels the garment has.
  const YAML::Node a = n["anchors"];
  if (!a.IsDefined() || (a.IsScalar() && a.Scalar() == "all")) {
    g.anchor_labels = g.all_anchor_labels;
  } else {
    if (!a.IsSequence()) P.Fail(a, path + ".anchors", "expected 'all' or a list of anchor labels, got " + P.Describe(a));
    g.anchor_labels = P.Strings(a, path + ".anchors");
    if (g.anchor_labels.empty()) P.Fail(a, path + ".anchors", "the list is empty");
    for (size_t i = 0; i < g.anchor_labels.size(); ++i) {
      const std::string& l = g.anchor_labels[i];
      const std::string ip = path + ".anchors[" + std::to_string(i) + "]";
      if (std::find(g.all_anchor_labels.begin(), g.all_anchor_labels.end(), l) == g.all_anchor_labels.end())
        P.Fail(a[i], ip,
               "anchor label '" + l + "' does not exist on " +
                   (g.template_name.empty() ? "'" + g.file.filename().string() + "'" : "template '" + g.template_name + "'") +
                   Suggest(l, g.all_anchor_labels) + "; labels: " + Join(g.all_anchor_labels));
      if (std::count(g.anchor_labels.begin(), g.anchor_labels.begin() + i, l)) P.Fail(a[i], ip, "label listed twice");
    }
  }
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
      P.Fail(n[i], ip, "instance " + std::to_string(v) + " out of range (the garment has " + std::to_string(count) +
                           " instances, numbered from 0)");
    if (std::count(out.begin(), out.end(), static_cast<int>(v))) P.Fail(n[i], ip, "instance listed twice");
    out.push_back(static_cast<int>(v));
  }
  if (out.empty()) P.Fail(n, path, "the list is empty");
  std::sort(out.begin(), out.end());
  return out;
}

void ParsePerturbation(const Parser& P, const YAML::Node& n, const std::string& path, Perturbation& pt) {
  P.CheckKeys(n, path, {"grasp_offset", "size_scale", "material_jitter"});
  P.DoubleTo(n, "grasp_offset", path, pt.grasp_offset, 0, 0.5);
  P.DoubleTo(n, "material_jitter", path, pt.material_jitter, 0, 0.9);
  if (n["size_scale"].IsDefined()) {
    const YAML::Node s = n["size_scale"];
    const std::string sp = path + ".size_scale";
    if (s.IsScalar()) {
      pt.size_scale_min = pt.size_scale_max = *P.Double(n, "size_scale", path, 0, 10, true);
    } else if (s.IsSequence() && s.size() == 2) {
      for (int i = 0; i < 2; ++i) {
        double v;
        try {
          v = s[i].as<double>();
        } catch (const YAML::Exception&) {
          P.Fail(s[i], sp + "[" + std::to_string(i) + "]", "expected a number, got " + P.Describe(s[i]));
        }
        if (!(v > 0 && v <= 10)) P.Fail(s[i], sp + "[" + std::to_string(i) + "]", "out of range (allowed (0, 10])");
        (i ? pt.size_scale_max : pt.size_scale_min) = v;
      }
      if (pt.size_scale_min > pt.size_scale_max) P.Fail(s, sp, "expected [min, max] with min <= max");
    } else {
      P.Fail(s, sp, "expected a number or [min, max], got " + P.Describe(s));
    }
  }
}

struct InstanceUse {
  std::string split;
  YAML::Mark mark;
};

void ParseSplits(const Parser& P, const YAML::Node& n, Recipe& r) {
  const std::vector<std::string> names = {"train", "calibration", "test"};
  P.CheckKeys(n, "splits", names);
  std::map<std::pair<std::string, int>, InstanceUse> used;
  for (const auto& split : names) {
    const YAML::Node s = n[split];
    if (!s.IsDefined()) continue;
    const std::string path = "splits." + split;
    P.CheckKeys(s, path, {"garments", "sensing", "perturbation", "repeats"});
    SplitSpec sp;
    sp.name = split;
    sp.sensing = P.String(s, "sensing", path).value_or(split == "train" ? "database" : "sensed");
    if (sp.sensing != "database" && sp.sensing != "sensed")
      P.Fail(s["sensing"], path + ".sensing",
             "unknown sensing kind '" + sp.sensing + "'" + Suggest(sp.sensing, {"database", "sensed"}) +
                 "; kinds: database, sensed");
    if (s["perturbation"].IsDefined()) ParsePerturbation(P, s["perturbation"], path + ".perturbation", sp.perturbation);
    P.IntTo(s, "repeats", path, sp.repeats, 1, 1000);
    const YAML::Node gl = s["garments"];
    if (!gl.IsDefined()) P.Fail(s, path, "missing key 'garments' (a list of {garment, instances, ...})");
    if (!gl.IsSequence()) P.Fail(gl, path + ".garments", "expected a list, got " + P.Describe(gl));
    if (gl.size() == 0) P.Fail(gl, path + ".garments", "the list is empty");
    for (size_t i = 0; i < gl.size(); ++i) {
      const YAML::Node e = gl[i];
      const std::string ep = path + ".garments[" + std::to_string(i) + "]";
      P.CheckKeys(e, ep, {"garment", "instances", "materials", "anchors", "max_anchors"});
      SplitSelector sel;
      const auto gname = P.String(e, "garment", ep);
      if (!gname) P.Fail(e, ep, "missing key 'garment'");
      const GarmentSpec* g = r.FindGarment(*gname);
      if (!g) {
        std::vector<std::string> gn;
        for (const auto& gg : r.garments) gn.push_back(gg.name);
        P.Fail(e["garment"], ep + ".garment",
               "unknown garment '" + *gname + "'" + Suggest(*gname, gn) + "; garments: " + Join(gn));
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
                       Suggest(sel.materials[k], g->materials) + "; its materials: " + Join(g->materials));
      }
      if (e["anchors"].IsDefined() && !(e["anchors"].IsScalar() && e["anchors"].Scalar() == "all")) {
        sel.anchors = P.Strings(e["anchors"], ep + ".anchors");
        if (sel.anchors.empty()) P.Fail(e["anchors"], ep + ".anchors", "the list is empty");
        for (size_t k = 0; k < sel.anchors.size(); ++k)
          if (std::find(g->anchor_labels.begin(), g->anchor_labels.end(), sel.anchors[k]) == g->anchor_labels.end())
            P.Fail(e["anchors"][k], ep + ".anchors[" + std::to_string(k) + "]",
                   "anchor label '" + sel.anchors[k] + "' is not among garment '" + g->name + "''s anchors" +
                       Suggest(sel.anchors[k], g->anchor_labels) + "; its anchors: " + Join(g->anchor_labels));
      }
      P.IntTo(e, "max_anchors", ep, sel.max_anchors, 1, 100000);
      // Splits are by garment instance: one instance belongs to one split only.
      const YAML::Node inode = e["instances"].IsDefined() ? e["instances"] : e;
      for (int inst : sel.instances) {
        auto [it, fresh] = used.insert({{g->name, inst}, {split, inode.Mark()}});
        if (!fresh)
          P.Fail(inode, ep + ".instances",
                 "instance " + std::to_string(inst) + " of '" + g->name + "' is already in split '" + it->second.split +
                     "' (line " + std::to_string(it->second.mark.line + 1) +
                     "); all anchors of one instance stay in one split");
      }
      sp.selectors.push_back(std::move(sel));
    }
    r.splits.push_back(std::move(sp));
  }
  if (r.splits.empty()) P.Fail(n, "splits", "no split given (train, calibration, test)");
  for (const auto& g : r.garments)
    for (int i = 0; i < g.instances; ++i)
      if (!used.count({g.name, i}))
        r.warnings.push_back("instance " + std::to_string(i) + " of garment '" + g.name + "' is in no split");
}

}  // namespace

Recipe ParseRecipe(const std::string& text, const std::string& file_label, const fs::path& base_dir,
                   const std::map<std::string, fs::path>* files) {
  YAML::Node loaded;
  try {
    loaded = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    std::ostringstream os;
    os << file_label << ":" << e.mark.line + 1 << ":" << e.mark.column + 1 << ": YAML syntax error: " << e.msg;
    throw Error(os.str());
  }
  const YAML::Node root = loaded;  // const: lookups must not insert keys
  Recipe r;
  r.file_label = file_label;
  r.text = text;
  Parser P0(file_label, base_dir, false);
  if (!root.IsMap()) P0.Fail(root, "(top level)", "a recipe is a mapping of keys (name, version, seed, garments, ...)");
  P0.CheckKeys(root, "", kTopKeys);
  P0.Bool(root, "allow_outside_paths", "", r.allow_outside_paths);
  const Parser P(file_label, base_dir, r.allow_outside_paths, files);

  r.name = P.Name(root, "name", "");
  const auto version = P.String(root, "version", "");
  if (!version) P.Fail(root, "version", "missing key 'version' (MAJOR.MINOR.PATCH)");
  if (!std::regex_match(*version, std::regex("(0|[1-9][0-9]*)\\.(0|[1-9][0-9]*)\\.(0|[1-9][0-9]*)")))
    P.Fail(root["version"], "version", "'" + *version + "' is not a semantic version MAJOR.MINOR.PATCH");
  r.version = *version;
  if (!root["seed"].IsDefined()) P.Fail(root, "seed", "missing key 'seed' (a non-negative integer)");
  {
    const YAML::Node s = root["seed"];
    try {
      r.seed = s.as<uint64_t>();
      if (!s.IsScalar() || s.Scalar().empty() || s.Scalar()[0] == '-') throw YAML::Exception(s.Mark(), "");
    } catch (const YAML::Exception&) {
      P.Fail(s, "seed", "expected a non-negative integer, got " + P.Describe(s));
    }
  }
  r.description = P.String(root, "description", "").value_or("");
  r.license = P.String(root, "license", "").value_or(r.license);

  // Materials: every preset by name, plus the recipe's own.
  for (const auto& m : MaterialPresets()) r.materials[m.name] = m;
  if (root["materials"].IsDefined()) {
    const YAML::Node ms = root["materials"];
    P.RequireMap(ms, "materials");
    for (auto it = ms.begin(); it != ms.end(); ++it) {
      const std::string name = it->first.Scalar();
      const std::string path = "materials." + name;
      if (!std::regex_match(name, kNameRe)) P.Fail(it->first, path, "not a valid name (letters, digits, '_' and '-')");
      if (FindMaterialPreset(name))
        P.Fail(it->first, path, "'" + name + "' is a preset name; give your material another name (preset: " + name + ")");
      r.materials[name] = ParseMaterial(P, name, it->second, path);
    }
  }

  if (root["simulation"].IsDefined()) ParseSimulation(P, root["simulation"], r.hang);

  // Sensing: database defaults to noise off, sensed to noise on; sensed inherits
  // every other key from database.
  {
    const YAML::Node s = root["sensing"];
    if (s.IsDefined()) P.CheckKeys(s, "sensing", {"database", "sensed"});
    SensingSpec db;
    db.sweep.kinect.noise = false;
    if (s.IsDefined() && s["database"].IsDefined()) ParseSensing(P, s["database"], "sensing.database", db);
    SensingSpec sensed = db;
    sensed.sweep.kinect.noise = true;
    if (s.IsDefined() && s["sensed"].IsDefined()) ParseSensing(P, s["sensed"], "sensing.sensed", sensed);
    if (!s.IsDefined() || !s["database"].IsDefined()) db.sweep.Validate();
    if (!s.IsDefined() || !s["sensed"].IsDefined()) sensed.sweep.Validate();
    r.sensing["database"] = db;
    r.sensing["sensed"] = sensed;
  }

  if (root["fusion"].IsDefined()) ParseFusion(P, root["fusion"], r.fusion);
  if (root["feature"].IsDefined()) ParseFeature(P, root["feature"], r.feature);

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

  if (root["splits"].IsDefined()) {
    ParseSplits(P, root["splits"], r);
  } else {
    // No splits: every instance is in train (the database).
    SplitSpec sp;
    sp.name = "train";
    sp.sensing = "database";
    for (const auto& g : r.garments) {
      SplitSelector sel;
      sel.garment = g.name;
      for (int i = 0; i < g.instances; ++i) sel.instances.push_back(i);
      sp.selectors.push_back(sel);
    }
    r.splits.push_back(sp);
  }
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
