// The runtime seen from Python: recognition against a release and registration, by the
// same library calls `drape recognize` and `drape register` make (RecognizeReleaseQuery,
// registration::RegisterAndEvaluate), so that the results are the CLI's.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/error.h"
#include "garments/io.h"
#include "generator/release/release.h"
#include "python/convert.h"
#include "runtime/recognition/calibrate.h"
#include "runtime/recognition/query_pipeline.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/recognition/release_query.h"
#include "runtime/recognition/release_source.h"
#include "runtime/registration/registration.h"

namespace drape::python {
namespace {

namespace fs = std::filesystem;
using namespace drape::recognition;

Database LoadDb(const Release& rel) {
  LoadReport lr;
  return LoadDatabase(rel, &lr);
}

// A release's database (train split) with its learned weights, loaded once.
class Runtime {
 public:
  // weights: "" = the release's calibration/weights.json if present, "none" = unweighted,
  // else a weights.json path (as `drape recognize --weights`).
  Runtime(const fs::path& dir, const std::string& weights)
      : rel_(Release::Open(dir)), db_(LoadDb(rel_)), weights_path_(ResolveWeightsPath(rel_, weights)) {
    if (!weights_path_.empty()) weights_ = LoadWeights(weights_path_, rel_.digest());
  }

  // kind: "entry" (value = id), "sweep" (folder), "mesh" (file), "feature" (uses `code`).
  // Returns JSON text: RecognizeReleaseQuery's, plus "weights" and "match_seconds".
  // category_fit: an entry query with a recon.ply and no category given takes its
  // category by registration, as `drape recognize --entry` does by default.
  std::string Recognize(const std::string& kind, const std::string& value, const std::optional<BoolArray>& feature,
                        const std::string& category, const std::string& instance, int top_k, bool weighted,
                        uint64_t seed, bool category_fit) const {
    ReleaseQuery q;
    if (kind == "entry")
      q.kind = ReleaseQuery::Kind::kEntry;
    else if (kind == "sweep")
      q.kind = ReleaseQuery::Kind::kSweep;
    else if (kind == "mesh")
      q.kind = ReleaseQuery::Kind::kMesh;
    else if (kind == "feature")
      q.kind = ReleaseQuery::Kind::kFeature, q.feature = FeatureFromArray(*feature, "feature");
    else
      throw Error("recognize: unknown query kind '" + kind + "'");
    q.value = value;
    q.seed = seed;
    ReleaseQueryOptions o;
    o.recognize.top_k = top_k;
    o.recognize.category = category;
    if (!instance.empty()) o.recognize.instances = {instance};
    o.recognize.weighted = weighted;
    o.category_fit = category_fit;
    const ReleaseQueryResult r = RecognizeReleaseQuery(rel_, db_, weights_ ? &*weights_ : nullptr, q, o);
    Json out = r.ToJson(db_);
    out["match_seconds"] = r.recognition.match_seconds;
    out["weights"] = weights_ ? Json(weights_path_.string()) : Json(nullptr);
    return out.dump();
  }

  // The query pipeline's feature (sweep folder or hung mesh file), featurised with the
  // release's recipe options.
  py::array_t<bool> PipelineFeature(const std::string& kind, const fs::path& path, uint64_t seed) const {
    if (kind != "sweep" && kind != "mesh") throw Error("extract_feature: unknown kind '" + kind + "'");
    return FeatureToArray(kind == "sweep" ? FeatureFromSweep(rel_, path, seed).code
                                          : FeatureFromMesh(rel_, path, seed).code);
  }

  int database_size() const { return db_.size(); }
  bool weighted() const { return weights_.has_value(); }

 private:
  Release rel_;
  Database db_;
  fs::path weights_path_;
  std::optional<Weights> weights_;
};

// A garment file with its anchors sidecar, as `drape register` reads SOURCE.
py::tuple ImportWithAnchors(const fs::path& mesh, const fs::path& anchors_json) {
  const Garment g = ImportGarment(mesh, anchors_json, ImportOptions{});
  py::list anchors;
  for (const Anchor& a : g.anchors) anchors.append(py::make_tuple(a.label, a.vertex));
  return py::make_tuple(ToArray(g.mesh.V), ToArray(g.mesh.F), anchors);
}

py::dict Register(const DoubleArray& sv, const IndexArray& sf, const DoubleArray& tv, const IndexArray& tf,
                  const std::vector<std::pair<std::string, int>>& anchors, bool rigid_only, bool scale,
                  std::optional<int> grid_cells, std::optional<double> kappa, std::optional<double> beta,
                  std::optional<double> alpha, std::optional<int> iterations) {
  const TriMesh source = MeshFromArrays(sv, sf, "source"), target = MeshFromArrays(tv, tf, "target");
  registration::RegistrationOptions opt;
  opt.nonrigid = !rigid_only;
  opt.scale = scale;
  if (grid_cells) opt.grid.cells = *grid_cells;
  if (kappa) opt.kappa = *kappa;
  if (beta) opt.beta = *beta;
  if (alpha) opt.alpha = *alpha;
  if (iterations) opt.lm.max_iterations = *iterations;
  opt.Validate();
  std::vector<registration::AnchorPair> pairs;
  pairs.reserve(anchors.size());
  for (const auto& [label, vertex] : anchors) pairs.push_back({label, vertex, false, Vec3::Zero()});
  registration::RegistrationResult result;
  registration::RegistrationEvaluation ev;
  {
    py::gil_scoped_release nogil;
    ev = registration::RegisterAndEvaluate(source, target, pairs, opt, &result);
  }
  py::dict out;
  out["report_json"] = registration::ToJson(ev).dump();
  out["rigid"] = MeshTuple(result.rigid);
  out["nonrigid"] = MeshTuple(opt.nonrigid ? result.nonrigid : result.rigid);
  return out;
}

}  // namespace

void BindRuntime(py::module_& m) {
  py::class_<Runtime>(m, "Runtime")
      .def(py::init<const fs::path&, const std::string&>(), py::arg("release"), py::arg("weights") = "")
      .def("recognize", &Runtime::Recognize, py::arg("kind"), py::arg("value"), py::arg("feature"), py::arg("category"),
           py::arg("instance"), py::arg("top_k"), py::arg("weighted"), py::arg("seed"), py::arg("category_fit"))
      .def("pipeline_feature", &Runtime::PipelineFeature, py::arg("kind"), py::arg("path"), py::arg("seed"))
      .def_property_readonly("database_size", &Runtime::database_size)
      .def_property_readonly("weighted", &Runtime::weighted);
  m.def("import_with_anchors", &ImportWithAnchors, py::arg("mesh"), py::arg("anchors_json"));
  m.def("register", &Register, py::arg("source_v"), py::arg("source_f"), py::arg("target_v"), py::arg("target_f"),
        py::arg("anchors"), py::arg("rigid_only"), py::arg("scale"), py::arg("grid_cells"), py::arg("kappa"),
        py::arg("beta"), py::arg("alpha"), py::arg("iterations"));
}

}  // namespace drape::python
