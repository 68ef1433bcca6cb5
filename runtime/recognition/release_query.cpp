// One recognition query against a release (see release_query.h).
#include "runtime/recognition/release_query.h"

#include "common/error.h"
#include "common/timing.h"
#include "runtime/recognition/query_pipeline.h"
#include "runtime/recognition/release_source.h"

namespace drape::recognition {
namespace {

namespace fs = std::filesystem;

// A release entry as the query: its stored feature (with `refuse` also re-fused from its
// kept sweep and compared), described in `query`, fusion/feature times from the build.
Code EntryQuery(const Release& rel, const ReleaseQuery& rq, Json& query, Json& timing) {
  const std::string& id = rq.value;
  const Release::EntryInfo* e = rel.Find(id);
  if (!e) throw Error("the release has no entry '" + id + "'");
  if (e->failed) throw Error("entry " + id + " failed in the build (" + e->failure + ")");
  const EntryLabel l = LabelFromEntry(*e);
  Code q = LoadEntryCode(rel, *e);
  query = {{"kind", "entry"},
           {"id", id},
           {"split", e->split},
           {"true_category", l.category},
           {"true_anchor", l.anchor},
           {"instance", l.instance},
           {"height", ReconHeight(rel, *e)}};
  if (e->split == "train") query["note"] = "a train entry is in the database: it matches itself at distance 0";
  const StageTiming st = EntryStageTiming(rel.build_info(), id);
  timing["fusion_seconds"] = st.fusion_seconds >= 0 ? Json(st.fusion_seconds) : Json(nullptr);
  timing["feature_seconds"] = st.feature_seconds >= 0 ? Json(st.feature_seconds) : Json(nullptr);
  timing["fusion_feature_source"] = st.source.empty() ? "not recorded by the build" : st.source;
  if (rq.refuse) {
    bool has_sweep = false;
    for (const auto& f : e->files) has_sweep |= f.path == "sweep/cameras.json";
    if (!has_sweep)
      throw Error("--refuse: entry " + id + " kept no sweep (the recipe's keep_frames is off for its split)");
    const PipelineResult pr = FeatureFromSweep(rel, rel.EntryPath(id, "sweep"), rq.seed);
    timing["refused"] = {{"read_seconds", pr.timing.read_seconds},
                         {"fusion_seconds", pr.timing.fusion_seconds},
                         {"feature_seconds", pr.timing.feature_seconds}};
    const Match m = DistanceReference(q, pr.code);
    query["refused_vs_stored_feature"] = {{"distance", m.distance}, {"rotation", m.rotation}};
  }
  return q;
}

// A recorded sweep or a hung mesh fused and featurised in this run.
Code FileQuery(const Release& rel, const ReleaseQuery& rq, Json& query, Json& timing) {
  const bool sweep = rq.kind == ReleaseQuery::Kind::kSweep;
  const PipelineResult pr = sweep ? FeatureFromSweep(rel, rq.value, rq.seed) : FeatureFromMesh(rel, rq.value, rq.seed);
  query = {{"kind", sweep ? "sweep" : "mesh"}, {"path", rq.value}, {"info", pr.info}, {"height", pr.height}};
  timing["read_seconds"] = pr.timing.read_seconds;
  if (!sweep) timing["sweep_seconds"] = pr.timing.sweep_seconds;
  timing["fusion_seconds"] = pr.timing.fusion_seconds;
  timing["feature_seconds"] = pr.timing.feature_seconds;
  timing["fusion_feature_source"] = "measured in this run";
  return pr.code;
}

}  // namespace

ReleaseQueryResult RecognizeReleaseQuery(const Release& release, const Database& db, const Weights* weights,
                                         const ReleaseQuery& query, const ReleaseQueryOptions& options) {
  ReleaseQueryResult res;
  res.timing = Json::object();
  Code q;
  switch (query.kind) {
    case ReleaseQuery::Kind::kEntry:
      q = EntryQuery(release, query, res.query, res.timing);
      break;
    case ReleaseQuery::Kind::kSweep:
    case ReleaseQuery::Kind::kMesh:
      q = FileQuery(release, query, res.query, res.timing);
      break;
    case ReleaseQuery::Kind::kFeature:
      q = query.feature;
      res.query = {{"kind", "feature"}};
      break;
  }
  RecognizeOptions o = options.recognize;
  o.query_height = res.query.value("height", 0.0);  // a bare feature has none: no height gates
  o.Validate();
  options.fit.Validate();
  const Recognizer rec(db, weights);
  // The category by registration where the query has a reconstruction and no category is given.
  if (options.category_fit && query.kind == ReleaseQuery::Kind::kEntry && o.category.empty() &&
      fs::exists(release.EntryPath(query.value, "recon.ply"))) {
    const auto t0 = Clock::now();
    const CategoryFit fit = EntryCategoryByFit(release, db, rec, q, o, query.value, options.fit);
    o.category = fit.category;
    res.category_fit = ToJson(fit);
    res.timing["category_fit_seconds"] = Since(t0);
  }
  res.recognition = rec.Recognize(q, o);
  if (!res.category_fit.is_null() && !o.category.empty()) res.recognition.category_source = "registration";
  res.timing["matching_seconds"] = res.recognition.match_seconds;
  const EntryLabel& bl = db.label(res.recognition.best.entry);
  res.anchor_hung = HungVertex(release, bl.id, bl.anchor_vertex);
  return res;
}

Json ReleaseQueryResult::ToJson(const Database& db) const {
  const EntryLabel& bl = db.label(recognition.best.entry);
  Json out{{"query", query},
           {"result", recognition::ToJson(recognition)},
           {"anchor_position",
            {{"entry", bl.id},
             {"vertex", bl.anchor_vertex},
             {"hung_object_frame", anchor_hung ? PointJson(*anchor_hung) : Json(nullptr)},
             {"flat_uv", bl.anchor_uv ? PointJson(*bl.anchor_uv) : Json(nullptr)}}},
           {"timing", timing}};
  if (!category_fit.is_null()) out["category_fit"] = category_fit;
  return out;
}

}  // namespace drape::recognition
