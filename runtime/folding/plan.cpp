#include "runtime/folding/plan.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "common/error.h"
#include "common/yaml.h"
#include "runtime/folding/keypoints.h"

namespace drape::folding {
namespace {

const std::regex kNameRe("[A-Za-z0-9][A-Za-z0-9_-]*");

std::string Describe(const YAML::Node& n) { return DescribeYaml(n); }

// Located errors and typed reads over yaml-cpp nodes.
class Reader {
 public:
  explicit Reader(std::string label) : label_(std::move(label)) {}

  [[noreturn]] void Fail(const YAML::Node& n, const std::string& path, const std::string& what) const {
    const YAML::Mark m = n.Mark();
    std::ostringstream os;
    os << label_ << ":" << (m.is_null() ? 0 : m.line + 1) << ":" << (m.is_null() ? 0 : m.column + 1) << ": " << path
       << ": " << what;
    throw Error(os.str());
  }

  void Keys(const YAML::Node& n, const std::string& path, const std::vector<std::string>& known,
            const std::vector<std::string>& required) const {
    if (!n.IsMap()) Fail(n, path, "expected a mapping, got " + Describe(n));
    std::set<std::string> seen;
    for (auto it = n.begin(); it != n.end(); ++it) {
      const std::string key = it->first.IsScalar() ? it->first.Scalar() : "";
      const std::string kp = path.empty() ? key : path + "." + key;
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
        Fail(it->first, kp, "unknown key; known keys here: " + list);
      }
      if (!seen.insert(key).second) Fail(it->first, kp, "key given twice");
    }
    for (const auto& r : required)
      if (!seen.count(r)) Fail(n, path, "missing key '" + r + "'");
  }

  std::string Str(const YAML::Node& n, const std::string& path) const {
    if (!n.IsScalar()) Fail(n, path, "expected a string, got " + Describe(n));
    return n.Scalar();
  }
  std::string Name(const YAML::Node& n, const std::string& path) const {
    std::string s = Str(n, path);
    if (!std::regex_match(s, kNameRe)) Fail(n, path, "'" + s + "' is not a valid name (letters, digits, '_', '-')");
    return s;
  }
  double Num(const YAML::Node& n, const std::string& path, double lo, double hi) const {
    const std::optional<double> parsed = YamlNumber(n);
    if (!parsed) Fail(n, path, "expected a number, got " + Describe(n));
    const double v = *parsed;
    if (!std::isfinite(v) || v < lo || v > hi) {
      std::ostringstream os;
      os << "out of range: " << n.Scalar() << " (allowed [" << lo << ", " << hi << "])";
      Fail(n, path, os.str());
    }
    return v;
  }
  int Line(const YAML::Node& n) const { return n.Mark().is_null() ? 0 : n.Mark().line + 1; }

 private:
  std::string label_;
};

// The key point names every category of the plan has.
std::set<std::string> CommonKeyPoints(const std::vector<std::string>& categories) {
  std::set<std::string> common;
  for (size_t i = 0; i < categories.size(); ++i) {
    const auto& names = KeyPointNames(categories[i]);
    std::set<std::string> s(names.begin(), names.end());
    if (i == 0) {
      common = s;
    } else {
      std::set<std::string> both;
      std::set_intersection(common.begin(), common.end(), s.begin(), s.end(), std::inserter(both, both.end()));
      common = both;
    }
  }
  return common;
}

PlanPoint ParsePoint(const Reader& rd, const YAML::Node& n, const std::string& path,
                     const std::set<std::string>& names) {
  auto key_point = [&](const YAML::Node& k, const std::string& p) {
    std::string s = rd.Name(k, p);
    if (!names.count(s)) {
      std::string list;
      for (const auto& x : names) list += (list.empty() ? "" : ", ") + x;
      rd.Fail(k, p, "unknown key point '" + s + "' (this plan's categories have: " + list + ")");
    }
    return s;
  };
  PlanPoint pt;
  pt.line = rd.Line(n);
  if (n.IsScalar()) {
    pt.a = key_point(n, path);
    return pt;
  }
  rd.Keys(n, path, {"at", "between", "t", "offset"}, {});
  if (n["at"].IsDefined() == n["between"].IsDefined()) rd.Fail(n, path, "give exactly one of 'at' and 'between'");
  if (n["at"].IsDefined()) {
    pt.a = key_point(n["at"], path + ".at");
    if (n["t"].IsDefined()) rd.Fail(n["t"], path + ".t", "'t' goes with 'between', not 'at'");
  } else {
    const YAML::Node b = n["between"];
    if (!b.IsSequence() || b.size() != 2) rd.Fail(b, path + ".between", "expected a list of two key points");
    pt.a = key_point(b[0], path + ".between[0]");
    pt.b = key_point(b[1], path + ".between[1]");
    if (!n["t"].IsDefined()) rd.Fail(n, path, "missing key 't' (0 = first point, 1 = second)");
    pt.t = rd.Num(n["t"], path + ".t", -1, 2);
  }
  if (n["offset"].IsDefined()) {
    const YAML::Node o = n["offset"];
    if (!o.IsSequence() || o.size() != 2) rd.Fail(o, path + ".offset", "expected [dx, dy] in metres");
    pt.offset = Vec2(rd.Num(o[0], path + ".offset[0]", -2, 2), rd.Num(o[1], path + ".offset[1]", -2, 2));
  }
  return pt;
}

PlanStep ParseStep(const Reader& rd, const YAML::Node& s, const std::string& p, const std::set<std::string>& names) {
  rd.Keys(s, p, {"name", "fold_line", "grasp", "gripper"}, {"name", "fold_line", "grasp"});
  PlanStep step;
  step.line = rd.Line(s);
  step.name = rd.Name(s["name"], p + ".name");
  const YAML::Node fl = s["fold_line"];
  if (!fl.IsSequence() || fl.size() != 2) rd.Fail(fl, p + ".fold_line", "expected a list of two points");
  step.line_from = ParsePoint(rd, fl[0], p + ".fold_line[0]", names);
  step.line_to = ParsePoint(rd, fl[1], p + ".fold_line[1]", names);
  const YAML::Node g = s["grasp"];
  if (!g.IsSequence() || g.size() < 1 || g.size() > 2)
    rd.Fail(g, p + ".grasp", "expected a list of one or two points (one per arm)");
  for (size_t k = 0; k < g.size(); ++k)
    step.grasps.push_back(ParsePoint(rd, g[k], p + ".grasp[" + std::to_string(k) + "]", names));
  if (s["gripper"].IsDefined()) {
    const std::string m = rd.Str(s["gripper"], p + ".gripper");
    if (m != "point" && m != "pinch") rd.Fail(s["gripper"], p + ".gripper", "'" + m + "' is not point or pinch");
    step.gripper = ParseGripperModel(m);
  }
  return step;
}

}  // namespace

FoldingPlan ParsePlan(const std::string& text, const std::string& file_label) {
  const Reader rd(file_label);
  const YAML::Node root = LoadYaml(text, file_label);
  FoldingPlan plan;
  plan.file_label = file_label;
  rd.Keys(root, "", {"plan", "description", "categories", "steps"}, {"plan", "categories", "steps"});
  plan.name = rd.Name(root["plan"], "plan");
  if (root["description"].IsDefined()) plan.description = rd.Str(root["description"], "description");
  const YAML::Node cats = root["categories"];
  if (!cats.IsSequence() || cats.size() == 0) rd.Fail(cats, "categories", "expected a non-empty list of categories");
  for (size_t i = 0; i < cats.size(); ++i) {
    const std::string p = "categories[" + std::to_string(i) + "]";
    const std::string c = rd.Name(cats[i], p);
    if (KeyPointNames(c).empty())
      rd.Fail(
          cats[i], p,
          "no key point detector for category '" + c + "' (known: towel, pants, shorts, long_sleeve_shirt, tshirt)");
    plan.categories.push_back(c);
  }
  const std::set<std::string> names = CommonKeyPoints(plan.categories);
  const YAML::Node steps = root["steps"];
  if (!steps.IsSequence() || steps.size() == 0) rd.Fail(steps, "steps", "expected a non-empty list of steps");
  std::set<std::string> step_names;
  for (size_t i = 0; i < steps.size(); ++i) {
    const std::string p = "steps[" + std::to_string(i) + "]";
    plan.steps.push_back(ParseStep(rd, steps[i], p, names));
    if (!step_names.insert(plan.steps.back().name).second)
      rd.Fail(steps[i]["name"], p + ".name", "step name '" + plan.steps.back().name + "' given twice");
  }
  return plan;
}

FoldingPlan LoadPlan(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot read the folding plan");
  std::stringstream ss;
  ss << in.rdbuf();
  return ParsePlan(ss.str(), path.string());
}

}  // namespace drape::folding
