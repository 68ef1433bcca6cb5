// drape._drape: the C++ libraries seen from Python (pybind11). Thin: every algorithm
// and file format lives in the C++ stages; this file only converts arguments and
// results (numpy arrays, JSON text that the Python side parses with json.loads).
// The Python package (python/drape/*.py) builds the user-facing API on top.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/error.h"
#include "common/files.h"
#include "garments/io.h"
#include "generator/feature/feature.h"
#include "generator/fusion/vdb_read.h"
#include "generator/release/release.h"
#include "generator/sweep/sweep.h"
#include "python/convert.h"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace drape::python {

py::array_t<double> ToArray(const Points3& V) {
  py::array_t<double> a({static_cast<py::ssize_t>(V.rows()), py::ssize_t(3)});
  std::copy(V.data(), V.data() + V.size(), a.mutable_data());
  return a;
}

py::array_t<int32_t> ToArray(const Faces& F) {
  py::array_t<int32_t> a({static_cast<py::ssize_t>(F.rows()), py::ssize_t(3)});
  std::copy(F.data(), F.data() + F.size(), a.mutable_data());
  return a;
}

// A row-major (n, 3) Eigen matrix as a numpy array of another element type.
template <class To, class Matrix>
py::array_t<To> Cast(const Matrix& M) {
  py::array_t<To> a({static_cast<py::ssize_t>(M.rows()), py::ssize_t(3)});
  std::copy(M.data(), M.data() + M.size(), a.mutable_data());
  return a;
}

py::tuple MeshTuple(const TriMesh& m) { return py::make_tuple(ToArray(m.V), ToArray(m.F)); }

TriMesh MeshFromArrays(const DoubleArray& V, const IndexArray& F, const std::string& what) {
  if (V.ndim() != 2 || V.shape(1) != 3) throw Error(what + ": vertices must have shape (V, 3)");
  if (F.ndim() != 2 || F.shape(1) != 3) throw Error(what + ": faces must have shape (F, 3)");
  TriMesh m;
  m.V.resize(V.shape(0), 3);
  std::copy(V.data(), V.data() + V.size(), m.V.data());
  m.F.resize(F.shape(0), 3);
  for (py::ssize_t i = 0; i < F.size(); ++i) {
    const int64_t f = F.data()[i];
    if (f < 0 || f >= V.shape(0)) throw Error(what + ": face index " + std::to_string(f) + " out of range");
    m.F.data()[i] = static_cast<int>(f);
  }
  return m;
}

// Feature ↔ numpy bool (layers, rings, sectors).
py::array_t<bool> FeatureToArray(const Feature& f) {
  py::array_t<bool> a({f.layers, f.rings, f.sectors});
  bool* out = a.mutable_data();
  for (int l = 0; l < f.layers; ++l)
    for (int r = 0; r < f.rings; ++r)
      for (int s = 0; s < f.sectors; ++s) *out++ = f.Get(l, r, s);
  return a;
}

Feature FeatureFromArray(const BoolArray& a, const std::string& what) {
  if (a.ndim() != 3) throw Error(what + ": a feature must have shape (layers, rings, sectors)");
  FeatureOptions o{static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)), static_cast<int>(a.shape(2))};
  o.Validate();
  Feature f;
  f.layers = o.layers, f.rings = o.rings, f.sectors = o.sectors;
  f.words.assign((f.NumBits() + 63) / 64, 0);
  const bool* in = a.data();
  for (int l = 0; l < f.layers; ++l)
    for (int r = 0; r < f.rings; ++r)
      for (int s = 0; s < f.sectors; ++s) f.Set(l, r, s, *in++);
  return f;
}

py::array_t<double> Matrix4(const Eigen::Matrix4d& m) {
  py::array_t<double> a({4, 4});
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) a.mutable_at(i, j) = m(i, j);
  return a;
}

py::dict ReadSdf(const fs::path& path) {
  const DenseSdf d = SdfGrid::Read(path).Dense();
  py::array_t<float> sdf({d.dims.x(), d.dims.y(), d.dims.z()}), weight({d.dims.x(), d.dims.y(), d.dims.z()});
  std::copy(d.sdf.begin(), d.sdf.end(), sdf.mutable_data());
  std::copy(d.weight.begin(), d.weight.end(), weight.mutable_data());
  py::dict out;
  out["sdf"] = sdf;
  out["weight"] = weight;
  out["index_to_object"] = Matrix4(d.IndexToObject());
  out["origin_index"] = py::make_tuple(d.origin.x(), d.origin.y(), d.origin.z());
  out["voxel_size"] = d.voxel_size;
  out["truncation"] = d.truncation;
  return out;
}

py::dict ReadSweepDict(const fs::path& dir) {
  const Sweep s = ReadSweep(dir);
  const int n = static_cast<int>(s.frames.size()), h = s.intrinsics.height, w = s.intrinsics.width;
  py::array_t<uint16_t> depth({n, h, w});
  py::array_t<double> c2o({n, 4, 4}), c2w({n, 4, 4}), angle(n);
  uint16_t* d = depth.mutable_data();
  for (int i = 0; i < n; ++i) {
    const DepthFrame& f = s.frames[i];
    if (static_cast<int>(f.depth.size()) != h * w)
      throw Error(dir.string() + ": frame " + std::to_string(i) + " has the wrong size");
    // ReadSweep gives metres from millimetre PNGs: back to the stored integers.
    for (float v : f.depth) *d++ = static_cast<uint16_t>(std::lround(double(v) * 1000.0));
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) {
        c2o.mutable_at(i, r, c) = f.camera_to_object.matrix()(r, c);
        c2w.mutable_at(i, r, c) = f.camera_to_world.matrix()(r, c);
      }
    angle.mutable_at(i) = f.gripper_angle;
  }
  py::dict K;
  K["width"] = w, K["height"] = h, K["fx"] = s.intrinsics.fx, K["fy"] = s.intrinsics.fy;
  K["cx"] = s.intrinsics.cx, K["cy"] = s.intrinsics.cy;
  py::dict out;
  out["depth_mm"] = depth;
  out["intrinsics"] = K;
  out["camera_to_object"] = c2o;
  out["camera_to_world"] = c2w;
  out["gripper_angle"] = angle;
  return out;
}

// 8-bit image as (H, W, 3) RGB or (H, W) grey; 16-bit PNGs as uint16.
py::array ReadImage(const fs::path& path) {
  if (!fs::is_regular_file(path)) throw Error(path.string() + ": no such file");
  cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (m.empty()) throw Error(path.string() + ": not a readable image");
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2RGB);
  if (m.channels() == 4) cv::cvtColor(m, m, cv::COLOR_BGRA2RGBA);
  std::vector<py::ssize_t> shape{m.rows, m.cols};
  if (m.channels() > 1) shape.push_back(m.channels());
  const size_t row = size_t(m.cols) * m.channels();  // values per image row
  if (m.depth() == CV_8U) {
    py::array_t<uint8_t> a(shape);
    for (int r = 0; r < m.rows; ++r) std::copy(m.ptr<uint8_t>(r), m.ptr<uint8_t>(r) + row, a.mutable_data() + r * row);
    return a;
  }
  if (m.depth() == CV_16U) {
    py::array_t<uint16_t> a(shape);
    for (int r = 0; r < m.rows; ++r)
      std::copy(m.ptr<uint16_t>(r), m.ptr<uint16_t>(r) + row, a.mutable_data() + r * row);
    return a;
  }
  throw Error(path.string() + ": unsupported pixel depth");
}

// Entries of a release as JSON text (the same fields entry.json holds).
std::string EntriesJson(const Release& r) {
  Json out = Json::array();
  for (const auto& e : r.entries()) {
    Json files = Json::array();
    for (const auto& f : e.files) files.push_back({{"path", f.path}, {"sha256", f.sha256}, {"size", f.size}});
    out.push_back({{"id", e.id},
                   {"key", e.key},
                   {"split", e.split},
                   {"failed", e.failed},
                   {"failure", e.failure},
                   {"record", e.record},
                   {"files", files},
                   {"entry_digest", e.entry_digest}});
  }
  return out.dump();
}

// Algorithm 1 on surface points with the field of a stored sdf.vdb.
py::array_t<bool> ExtractFeatureVdb(const DoubleArray& points, const fs::path& vdb, int layers, int rings, int sectors,
                                    const std::string& origin) {
  if (points.ndim() != 2 || points.shape(1) != 3) throw Error("extract_feature: points must have shape (P, 3)");
  Points3 P(points.shape(0), 3);
  std::copy(points.data(), points.data() + points.size(), P.data());
  const SdfGrid grid = SdfGrid::Read(vdb);
  FeatureOptions o{layers, rings, sectors, origin};
  o.Validate();
  Feature f;
  {
    py::gil_scoped_release nogil;
    f = ExtractFeature(
        P, [&grid](const Vec3& p) { return grid.Sample(p); }, o);
  }
  return FeatureToArray(f);
}

}  // namespace drape::python

PYBIND11_MODULE(_drape, m) {
  using namespace drape;
  using namespace drape::python;
  m.doc() = "drape's C++ libraries (use the `drape` package, not this module)";
  static py::exception<Error> drape_error(m, "DrapeError", PyExc_ValueError);
  // By value: pybind11 stores the translator as void (*)(std::exception_ptr).
  // NOLINTNEXTLINE(performance-unnecessary-value-param)
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(drape_error.ptr(), e.what());
    } catch (const NumericalError& e) {
      PyErr_SetString(PyExc_ArithmeticError, e.what());
    }
  });

  py::class_<Release>(m, "Release")
      .def(py::init([](const fs::path& dir) { return Release::Open(dir); }), py::arg("path"))
      .def("dataset_json", [](const Release& r) { return r.dataset().dump(); })
      .def("entries_json", &EntriesJson)
      .def("entry_path", &Release::EntryPath, py::arg("id"), py::arg("path") = "")
      .def("digest", &Release::digest)
      .def("dir", [](const Release& r) { return r.dir(); });

  m.def(
      "read_mesh",
      [](const fs::path& p, const std::string& vertex_dtype, const std::string& face_dtype) {
        if (vertex_dtype != "float64" && vertex_dtype != "float32")
          throw Error("read_mesh: vertex_dtype must be float64 or float32, not '" + vertex_dtype + "'");
        if (face_dtype != "int32" && face_dtype != "int64")
          throw Error("read_mesh: face_dtype must be int32 or int64, not '" + face_dtype + "'");
        const TriMesh mesh = ReadMesh(p);
        // Converted here, in one copy, to what the caller keeps (torch wants float32 and int64).
        py::object V = vertex_dtype == "float32" ? py::object(Cast<float>(mesh.V)) : py::object(ToArray(mesh.V));
        py::object F = face_dtype == "int64" ? py::object(Cast<int64_t>(mesh.F)) : py::object(ToArray(mesh.F));
        return py::make_tuple(V, F);
      },
      py::arg("path"), py::arg("vertex_dtype") = "float64", py::arg("face_dtype") = "int32",
      "(V (n, 3), F (m, 3)) of any mesh file drape or assimp reads; float64 and int32 unless asked otherwise");
  m.def("encode_ply", [](const DoubleArray& V, const IndexArray& F) {
    return py::bytes(EncodeMesh(MeshFromArrays(V, F, "mesh"), "ply"));
  });
  m.def(
      "read_feature", [](const fs::path& p) { return FeatureToArray(DecodeFeature(ReadFile(p), p.string())); },
      py::arg("path"));
  m.def("decode_feature", [](const py::bytes& b, const std::string& where) {
    return FeatureToArray(DecodeFeature(std::string(b), where));
  });
  m.def("encode_feature", [](const BoolArray& a) { return py::bytes(EncodeFeature(FeatureFromArray(a, "feature"))); });
  m.def("read_sdf", &ReadSdf, py::arg("path"));
  m.def("read_sweep", &ReadSweepDict, py::arg("dir"));
  m.def("read_image", &ReadImage, py::arg("path"));
  m.def(
      "match",
      [](const BoolArray& a, const BoolArray& b) {
        const Match r = Distance(FeatureFromArray(a, "f1"), FeatureFromArray(b, "f2"));
        return py::make_tuple(r.distance, r.rotation);
      },
      py::arg("f1"), py::arg("f2"));
  m.def("extract_feature_vdb", &ExtractFeatureVdb, py::arg("points"), py::arg("vdb"), py::arg("layers"),
        py::arg("rings"), py::arg("sectors"), py::arg("origin") = "top_layer");
  BindRuntime(m);
}
