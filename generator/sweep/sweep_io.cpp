// Sweep files: 16-bit PNG depth (mm) + cameras.json, Open3D and TUM lists; previews.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/files.h"
#include "common/format.h"
#include "common/json.h"
#include "generator/sweep/sweep.h"

namespace drape {
namespace {

constexpr double kDepthScale = 1000.0;  // PNG value per metre

std::string FrameName(int i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06d.png", i);
  return buf;
}

Json RowMajor(const Eigen::Isometry3d& T) {
  Json a = Json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) a.push_back(T.matrix()(r, c));
  return a;
}

Eigen::Isometry3d FromRowMajor(const Json& a, const std::string& where) {
  if (!a.is_array() || a.size() != 16) throw Error(where + ": expected 16 numbers (4×4 row-major)");
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      if (!a[r * 4 + c].is_number()) throw Error(where + ": not a number");
      M(r, c) = a[r * 4 + c].get<double>();
    }
  Eigen::Isometry3d T;
  T.matrix() = M;
  return T;
}

Json OptionsJson(const SweepOptions& o) {
  const KinectOptions& k = o.kinect;
  Json kj = {{"min_range", k.min_range},
             {"max_range", k.max_range},
             {"noise", k.noise},
             {"axial", k.axial},
             {"lateral", k.lateral},
             {"quantize", k.quantize},
             {"dropouts", k.dropouts},
             {"baseline", k.baseline},
             {"disparity_focal", k.disparity_focal},
             {"disparity_subpixel", k.disparity_subpixel},
             {"grazing_start_deg", k.grazing_start_deg},
             {"grazing_full_deg", k.grazing_full_deg},
             {"edge_jump", k.edge_jump},
             {"edge_dropout_probability", k.edge_dropout_probability},
             {"projector_shadow", k.projector_shadow}};
  return Json{{"frames", o.frames},
              {"degrees", o.degrees},
              {"back_and_forth", o.back_and_forth},
              {"frame_rate", o.frame_rate},
              {"camera_height", o.camera_height},
              {"camera_distance", o.camera_distance},
              {"gripper_height", o.gripper_height},
              {"look_at_height", o.look_at_height},
              {"scene", o.scene},
              {"embree_isa", o.embree_isa},
              {"kinect", kj}};
}

template <typename T>
void Get(const Json& j, const char* key, T& out, const std::string& where) {
  if (!j.contains(key)) return;  // older files: keep the default
  try {
    out = j.at(key).get<T>();
  } catch (const std::exception&) {
    throw Error(where + "." + key + ": wrong type");
  }
}

SweepOptions OptionsFromJson(const Json& j, const std::string& where) {
  SweepOptions o;
  if (!j.is_object()) return o;
  Get(j, "frames", o.frames, where);
  Get(j, "degrees", o.degrees, where);
  Get(j, "back_and_forth", o.back_and_forth, where);
  Get(j, "frame_rate", o.frame_rate, where);
  Get(j, "camera_height", o.camera_height, where);
  Get(j, "camera_distance", o.camera_distance, where);
  Get(j, "gripper_height", o.gripper_height, where);
  Get(j, "look_at_height", o.look_at_height, where);
  Get(j, "scene", o.scene, where);
  Get(j, "embree_isa", o.embree_isa, where);
  if (j.contains("kinect")) {
    const Json& k = j["kinect"];
    const std::string w = where + ".kinect";
    KinectOptions& ko = o.kinect;
    Get(k, "min_range", ko.min_range, w);
    Get(k, "max_range", ko.max_range, w);
    Get(k, "noise", ko.noise, w);
    Get(k, "axial", ko.axial, w);
    Get(k, "lateral", ko.lateral, w);
    Get(k, "quantize", ko.quantize, w);
    Get(k, "dropouts", ko.dropouts, w);
    Get(k, "baseline", ko.baseline, w);
    Get(k, "disparity_focal", ko.disparity_focal, w);
    Get(k, "disparity_subpixel", ko.disparity_subpixel, w);
    Get(k, "grazing_start_deg", ko.grazing_start_deg, w);
    Get(k, "grazing_full_deg", ko.grazing_full_deg, w);
    Get(k, "edge_jump", ko.edge_jump, w);
    Get(k, "edge_dropout_probability", ko.edge_dropout_probability, w);
    Get(k, "projector_shadow", ko.projector_shadow, w);
  }
  return o;
}

std::string EncodePng(const cv::Mat& image) {
  std::vector<uchar> buf;
  // Fixed parameters: same pixels → same bytes (for a given zlib).
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 1, cv::IMWRITE_PNG_STRATEGY,
                                   cv::IMWRITE_PNG_STRATEGY_DEFAULT};
  if (!cv::imencode(".png", image, buf, params)) throw Error("sweep: PNG encoding failed");
  return std::string(buf.begin(), buf.end());
}

}  // namespace

std::vector<std::pair<std::string, std::string>> EncodeSweep(const Sweep& sweep) {
  const Intrinsics& K = sweep.intrinsics;
  std::vector<std::pair<std::string, std::string>> files;
  Json frames = Json::array();
  Json trajectory = Json::array();
  std::string depth_txt = "# depth maps (16-bit PNG, millimetres, 0 = no data)\n# timestamp filename\n";
  std::string gt_txt =
      "# camera_to_object poses (object frame: grasp point at the origin, y up)\n"
      "# timestamp tx ty tz qx qy qz qw\n";
  for (size_t i = 0; i < sweep.frames.size(); ++i) {
    const DepthFrame& f = sweep.frames[i];
    if (f.depth.size() != size_t(K.width) * K.height)
      throw Error("sweep: frame " + std::to_string(i) + " has " + std::to_string(f.depth.size()) +
                  " pixels, intrinsics say " + std::to_string(K.width) + "x" + std::to_string(K.height));
    cv::Mat m(K.height, K.width, CV_16UC1);
    for (int v = 0; v < K.height; ++v) {
      auto* row = m.ptr<uint16_t>(v);
      for (int u = 0; u < K.width; ++u) {
        const double z = f.depth[size_t(v) * K.width + u];
        row[u] = (z > 0 && std::isfinite(z)) ? uint16_t(std::clamp(std::lround(z * kDepthScale), 0L, 65535L)) : 0;
      }
    }
    const std::string name = FrameName(int(i));
    files.emplace_back("sweep/" + name, EncodePng(m));
    const double t = double(i) / sweep.options.frame_rate;
    frames.push_back(Json{{"file", name},
                          {"timestamp", t},
                          {"gripper_angle", f.gripper_angle},
                          {"camera_to_object", RowMajor(f.camera_to_object)},
                          {"camera_to_world", RowMajor(f.camera_to_world)}});
    // Open3D: extrinsic = world(object)→camera, column-major.
    const Eigen::Matrix4d E = f.camera_to_object.inverse().matrix();
    Json ext = Json::array();
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) ext.push_back(E(r, c));
    trajectory.push_back(Json{{"class_name", "PinholeCameraParameters"},
                              {"extrinsic", ext},
                              {"intrinsic",
                               {{"height", K.height},
                                {"intrinsic_matrix", {K.fx, 0.0, 0.0, 0.0, K.fy, 0.0, K.cx, K.cy, 1.0}},
                                {"width", K.width}}},
                              {"version_major", 1},
                              {"version_minor", 0}});
    depth_txt += FormatFixed(t, 6) + " " + name + "\n";
    const Eigen::Quaterniond q(f.camera_to_object.linear());
    const Vec3 p = f.camera_to_object.translation();
    gt_txt += FormatFixed(t, 6) + " " + FormatFixed(p.x(), 9) + " " + FormatFixed(p.y(), 9) + " " +
              FormatFixed(p.z(), 9) + " " + FormatFixed(q.x(), 9) + " " + FormatFixed(q.y(), 9) + " " +
              FormatFixed(q.z(), 9) + " " + FormatFixed(q.w(), 9) + "\n";
  }
  Json cameras = {{"format", "drape.sweep"},
                  {"version", 1},
                  {"description",
                   "Synthetic Kinect v1 sweep of a hung garment turning about the vertical axis through "
                   "the gripper. Depth: 16-bit PNG, value/depth_scale = z-depth in metres, 0 = no data. "
                   "Camera: x right, y down, z forward. Poses: 4x4 row-major; camera_to_object maps "
                   "camera coordinates into the object frame (grasp point at the origin, y up)."},
                  {"intrinsics",
                   {{"width", K.width}, {"height", K.height}, {"fx", K.fx}, {"fy", K.fy}, {"cx", K.cx}, {"cy", K.cy}}},
                  {"depth_scale", kDepthScale},
                  {"seed", sweep.seed},
                  {"options", OptionsJson(sweep.options)},
                  {"frames", frames}};
  files.emplace_back("sweep/cameras.json", cameras.dump(1) + "\n");
  Json traj = {{"class_name", "PinholeCameraTrajectory"},
               {"parameters", trajectory},
               {"version_major", 1},
               {"version_minor", 0}};
  files.emplace_back("sweep/trajectory.json", traj.dump(1) + "\n");
  files.emplace_back("sweep/depth.txt", depth_txt);
  files.emplace_back("sweep/groundtruth.txt", gt_txt);
  return files;
}

Sweep ReadSweep(const std::filesystem::path& dir) {
  const std::filesystem::path cam_path = dir / "cameras.json";
  const std::string where = cam_path.string();
  Json j;
  try {
    j = Json::parse(ReadFile(cam_path));
  } catch (const Json::exception& e) {
    throw Error(where + ": invalid JSON: " + e.what());
  }
  Sweep sweep;
  try {
    const Json& k = j.at("intrinsics");
    sweep.intrinsics.width = k.at("width").get<int>();
    sweep.intrinsics.height = k.at("height").get<int>();
    sweep.intrinsics.fx = k.at("fx").get<double>();
    sweep.intrinsics.fy = k.at("fy").get<double>();
    sweep.intrinsics.cx = k.at("cx").get<double>();
    sweep.intrinsics.cy = k.at("cy").get<double>();
  } catch (const Json::exception& e) {
    throw Error(where + ": intrinsics: " + e.what());
  }
  const double scale = j.value("depth_scale", kDepthScale);
  if (!(scale > 0)) throw Error(where + ": depth_scale must be > 0");
  if (j.contains("seed") && j["seed"].is_number_unsigned()) sweep.seed = j["seed"].get<uint64_t>();
  if (j.contains("options")) sweep.options = OptionsFromJson(j["options"], where + ": options");
  sweep.options.kinect.intrinsics = sweep.intrinsics;
  if (!j.contains("frames") || !j["frames"].is_array()) throw Error(where + ": no frames array");
  const Intrinsics& K = sweep.intrinsics;
  for (size_t i = 0; i < j["frames"].size(); ++i) {
    const Json& fj = j["frames"][i];
    const std::string fw = where + ": frames[" + std::to_string(i) + "]";
    if (!fj.contains("file") || !fj["file"].is_string()) throw Error(fw + ": no file");
    DepthFrame f;
    f.camera_to_object = FromRowMajor(fj.value("camera_to_object", Json()), fw + ".camera_to_object");
    if (fj.contains("camera_to_world"))
      f.camera_to_world = FromRowMajor(fj["camera_to_world"], fw + ".camera_to_world");
    f.gripper_angle = fj.value("gripper_angle", 0.0);
    const std::filesystem::path png = dir / fj["file"].get<std::string>();
    const std::string bytes = ReadFile(png);
    cv::Mat m =
        cv::imdecode(cv::Mat(1, int(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())), cv::IMREAD_UNCHANGED);
    if (m.empty()) throw Error(png.string() + ": not a readable image");
    if (m.type() != CV_16UC1) throw Error(png.string() + ": expected a 16-bit single-channel PNG");
    if (m.cols != K.width || m.rows != K.height)
      throw Error(png.string() + ": size " + std::to_string(m.cols) + "x" + std::to_string(m.rows) +
                  " does not match the intrinsics");
    f.depth.resize(size_t(K.width) * K.height);
    for (int v = 0; v < K.height; ++v) {
      const auto* row = m.ptr<uint16_t>(v);
      for (int u = 0; u < K.width; ++u) f.depth[size_t(v) * K.width + u] = float(row[u] / scale);
    }
    sweep.frames.push_back(std::move(f));
  }
  sweep.options.frames = int(sweep.frames.size());
  sweep.stats.frames = int(sweep.frames.size());
  return sweep;
}

std::string RenderDepthPreview(const DepthFrame& frame, const Intrinsics& K) {
  const size_t n = size_t(K.width) * K.height;
  if (frame.depth.size() != n) throw Error("sweep preview: frame size does not match the intrinsics");
  std::vector<float> valid;
  valid.reserve(n);
  for (float z : frame.depth)
    if (z > 0 && std::isfinite(z)) valid.push_back(z);
  double lo = 0.5, hi = 4.0;
  if (!valid.empty()) {
    // 1st–99th percentile, so that a few far wall pixels do not flatten the garment.
    auto at = [&](double q) {
      size_t k = std::min(valid.size() - 1, size_t(q * (valid.size() - 1)));
      std::nth_element(valid.begin(), valid.begin() + k, valid.end());
      return double(valid[k]);
    };
    lo = at(0.01);
    hi = at(0.99);
    if (hi - lo < 0.05) hi = lo + 0.05;
  }
  cv::Mat gray(K.height, K.width, CV_8UC1);
  cv::Mat mask(K.height, K.width, CV_8UC1);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const float z = frame.depth[size_t(v) * K.width + u];
      const bool ok = z > 0 && std::isfinite(z);
      mask.at<uchar>(v, u) = ok ? 255 : 0;
      // Near = 255 (red in TURBO), far = 0 (blue).
      gray.at<uchar>(v, u) = ok ? cv::saturate_cast<uchar>(255.0 * (hi - z) / (hi - lo)) : 0;
    }
  cv::Mat colour;
  cv::applyColorMap(gray, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), mask == 0);
  // Canvas with a colour bar and labels on the right.
  const int bar_w = 110;
  cv::Mat canvas(K.height, K.width + bar_w, CV_8UC3, cv::Scalar(255, 255, 255));
  colour.copyTo(canvas(cv::Rect(0, 0, K.width, K.height)));
  const int top = 30, bottom = K.height - 40, x0 = K.width + 12, x1 = x0 + 20;
  if (bottom > top) {
    cv::Mat ramp(bottom - top, 1, CV_8UC1);
    for (int r = 0; r < ramp.rows; ++r)
      ramp.at<uchar>(r, 0) = cv::saturate_cast<uchar>(255.0 * (1.0 - double(r) / std::max(1, ramp.rows - 1)));
    cv::Mat ramp_c;
    cv::applyColorMap(ramp, ramp_c, cv::COLORMAP_TURBO);
    cv::resize(ramp_c, ramp_c, cv::Size(x1 - x0, ramp.rows), 0, 0, cv::INTER_NEAREST);
    ramp_c.copyTo(canvas(cv::Rect(x0, top, x1 - x0, ramp.rows)));
    for (int t = 0; t <= 4; ++t) {
      const int y = top + (bottom - top - 1) * t / 4;
      const double z = lo + (hi - lo) * t / 4;
      cv::line(canvas, {x1, y}, {x1 + 5, y}, cv::Scalar(0, 0, 0), 1);
      cv::putText(canvas, FormatFixed(z, 2) + " m", {x1 + 8, y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
                  cv::Scalar(0, 0, 0), 1, cv::LINE_8);
    }
    cv::putText(canvas, "depth", {x0, top - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_8);
    cv::putText(canvas, "black:", {x0, K.height - 22}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1,
                cv::LINE_8);
    cv::putText(canvas, "no data", {x0, K.height - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1,
                cv::LINE_8);
  }
  return EncodePng(canvas);
}

}  // namespace drape
