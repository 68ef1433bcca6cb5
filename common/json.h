// JSON for every file drape writes. ordered_json keeps keys in insertion order so
// that written files, and the hashes over them, are byte-stable.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace drape {
using Json = nlohmann::ordered_json;

// A point, vector or pattern coordinate as the JSON array [x, y(, z)], the one form every
// file and report uses (metres unless the key says otherwise).
inline Json PointJson(const Eigen::Vector3d& p) { return Json::array({p.x(), p.y(), p.z()}); }
inline Json PointJson(const Eigen::Vector2d& p) { return Json::array({p.x(), p.y()}); }
}  // namespace drape
