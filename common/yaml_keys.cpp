#include "common/yaml_keys.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>

#include "common/yaml.h"

namespace drape {

void YamlKeyReader::Fail(const YAML::Mark& m, const std::string& path, const std::string& what) const {
  std::ostringstream os;
  os << label_ << ":" << (m.is_null() ? 0 : m.line + 1) << ":" << (m.is_null() ? 0 : m.column + 1) << ": " << path
     << ": " << what;
  throw Error(os.str());
}

void YamlKeyReader::RequireMap(const YAML::Node& n, const std::string& path) const {
  if (!n.IsMap()) Fail(n, path, "expected a mapping, got " + DescribeYaml(n));
}

void YamlKeyReader::CheckKeys(const YAML::Node& n, const std::string& path,
                              const std::vector<std::string>& known) const {
  RequireMap(n, path);
  std::set<std::string> seen;
  for (auto it = n.begin(); it != n.end(); ++it) {
    const YAML::Node k = it->first;  // a copy: it-> returns a proxy that dies with this statement
    if (!k.IsScalar()) Fail(k, path, "keys must be plain names");
    const std::string& key = k.Scalar();
    const std::string kp = Sub(path, key);
    if (std::find(known.begin(), known.end(), key) == known.end())
      Fail(k, kp, "unknown key" + Suggest(key, known) + "; known keys here: " + JoinNames(known));
    if (!seen.insert(key).second) Fail(k, kp, "key given twice");
  }
}

YAML::Node YamlKeyReader::KeyNode(const YAML::Node& map, const std::string& key) {
  for (auto it = map.begin(); it != map.end(); ++it)
    if (it->first.Scalar() == key) return it->first;
  return YAML::Node();
}

std::optional<double> YamlKeyReader::Double(const YAML::Node& map, const std::string& key,
                                            const std::string& path) const {
  const YAML::Node n = map[key];
  if (!n.IsDefined()) return std::nullopt;
  return Number(n, Sub(path, key));
}

double YamlKeyReader::Number(const YAML::Node& n, const std::string& path) const {
  const std::optional<double> v = YamlNumber(n);
  if (!v) Fail(n, path, "expected a number, got " + DescribeYaml(n));
  if (!std::isfinite(*v)) Fail(n, path, "must be finite");
  return *v;
}

std::optional<std::string> YamlKeyReader::String(const YAML::Node& map, const std::string& key,
                                                 const std::string& path) const {
  const YAML::Node n = map[key];
  if (!n.IsDefined()) return std::nullopt;
  if (!n.IsScalar()) Fail(n, Sub(path, key), "expected a string, got " + DescribeYaml(n));
  return n.Scalar();
}

void YamlKeyReader::Bool(const YAML::Node& map, const std::string& key, const std::string& path, bool& out) const {
  const YAML::Node n = map[key];
  if (!n.IsDefined()) return;
  const std::string s = n.IsScalar() ? n.Scalar() : "";
  if (s == "true")
    out = true;
  else if (s == "false")
    out = false;
  else
    Fail(n, Sub(path, key), "expected true or false, got " + DescribeYaml(n));
}

void YamlKeyReader::Read(const YAML::Node& map, const std::string& key, const std::string& path, double& out) const {
  if (auto v = Double(map, key, path)) out = *v;
}

void YamlKeyReader::Read(const YAML::Node& map, const std::string& key, const std::string& path, int& out) const {
  const YAML::Node n = map[key];
  if (!n.IsDefined()) return;
  const std::string p = Sub(path, key);
  if (!n.IsScalar()) Fail(n, p, "expected an integer, got " + DescribeYaml(n));
  long long v;
  try {
    v = n.as<long long>();
  } catch (const YAML::Exception&) {
    Fail(n, p, "expected an integer, got " + DescribeYaml(n));
  }
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    Fail(n, p, "out of range for an integer: " + n.Scalar());
  out = static_cast<int>(v);
}

void YamlKeyReader::Read(const YAML::Node& map, const std::string& key, const std::string& path,
                         std::string& out) const {
  if (auto v = String(map, key, path)) out = *v;
}

void YamlKeyReader::Read(const YAML::Node& map, const std::string& key, const std::string& path, bool& out) const {
  Bool(map, key, path, out);
}

}  // namespace drape
