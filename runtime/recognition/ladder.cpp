#include "runtime/recognition/ladder.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "common/error.h"
#include "common/files.h"
#include "garments/io.h"
#include "garments/render.h"
#include "runtime/recognition/release_recipe.h"
#include "runtime/recognition/report_format.h"

namespace drape::recognition {

namespace fs = std::filesystem;

namespace {

bool OnlyTrainInstances(const Recipe& r, const SplitSpec& s) {
  std::set<std::pair<std::string, int>> train;
  for (const auto& sp : r.splits)
    if (sp.name == "train")
      for (const auto& sel : sp.selectors)
        for (int i : sel.instances) train.insert({sel.garment, i});
  for (const auto& sel : s.selectors)
    for (int i : sel.instances)
      if (!train.count({sel.garment, i})) return false;
  return true;
}

}  // namespace

std::vector<LadderRung> LadderRungs(const Release& release, const Recipe& r) {
  std::set<std::string> present;
  for (const auto& e : release.entries()) present.insert(e.split);
  std::vector<LadderRung> same, other;
  const SplitSpec* test = nullptr;
  for (const auto& s : r.splits) {
    if (s.name == "test") test = &s;
    if (s.name.rfind("test_", 0) != 0 || !present.count(s.name)) continue;
    LadderRung rung{s.name, DescribeSplit(s), OnlyTrainInstances(r, s)};
    rung.differs = (rung.database_instances ? "database entry, " : "other instance, ") + rung.differs;
    (rung.database_instances ? same : other).push_back(rung);
  }
  if (same.empty() && other.empty()) return {};
  if (test && present.count("test")) same.push_back({"test", "other instance, " + DescribeSplit(*test), false});
  same.insert(same.end(), other.begin(), other.end());
  return same;
}

Json LadderTable(const std::vector<LadderResult>& results) {
  Json cats = Json::object();
  for (const auto& lr : results) {
    std::vector<Json> rows(lr.eval.report["categories"].begin(), lr.eval.report["categories"].end());
    rows.push_back(lr.eval.report["overall"]);
    for (const Json& c : rows) {
      const Json& both = c["pose_accuracy"]["both"];
      cats[c["category"].get<std::string>()].push_back(
          {{"split", lr.rung.split},
           {"differs", lr.rung.differs},
           {"database_instances", lr.rung.database_instances},
           {"queries", c["queries"]},
           {"pose_unweighted", both["unweighted"]},
           {"pose_learned", both["learned"]},
           {"category_accuracy", c["category_accuracy"]},
           {"pose_learned_twin_credited",
            c.value("pose_accuracy_twin_credited", Json::object()).value("learned", Json())},
           {"pose_unweighted_twin_credited",
            c.value("pose_accuracy_twin_credited", Json::object()).value("unweighted", Json())},
           {"grasp_error_cm_unweighted", c["grasp_error_cm"]["unweighted_mean"]}});
    }
  }
  return cats;
}

std::string LadderMarkdown(const Json& table) {
  std::ostringstream md;
  md << "## Ablation ladder (pose accuracy, both database instances, category known)\n\n"
     << "Each rung adds one difference between a database entry and the query; the drop from one "
        "row to the next is what that difference costs. Twin credited: the anchor's symmetry twins (left/right, "
        "for the towel also top/bottom) count as right — indistinguishable in principle where front and back "
        "are alike (towel, skirt), told apart by the front/back difference of shirts and trousers.\n";
  for (const auto& [cat, rows] : table.items()) {
    md << "\n### " << cat
       << "\n\n| rung | queries | differs from the database entry by | pose (unweighted) | "
          "pose (learned) | twin credited (u / l) | category | grasp error cm (u) |\n"
          "|---|---|---|---|---|---|---|---|\n";
    for (const Json& r : rows) {
      char ge[32] = "n/a";
      if (!r["grasp_error_cm_unweighted"].is_null())
        std::snprintf(ge, sizeof ge, "%.1f", r["grasp_error_cm_unweighted"].get<double>());
      md << "| " << r["split"].get<std::string>() << " | " << r["queries"].get<int>() << " | "
         << r["differs"].get<std::string>() << " | " << PercentCell(r["pose_unweighted"]) << " | "
         << PercentCell(r["pose_learned"]) << " | " << PercentCell(r.value("pose_unweighted_twin_credited", Json()))
         << " / " << PercentCell(r.value("pose_learned_twin_credited", Json())) << " | "
         << PercentCell(r["category_accuracy"]) << " | " << ge << " |\n";
    }
  }
  return md.str();
}

namespace {

// The three meshes side by side at one scale, captions above.
void DrawTriptych(const std::vector<TriMesh>& meshes, const std::vector<std::string>& captions, const fs::path& path) {
  const int pw = 260, ph = 340, top = 40;
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (const auto& m : meshes) {
    if (m.NumVertices() == 0) continue;
    lo = lo.cwiseMin(Eigen::Vector2d(m.V.col(0).minCoeff(), m.V.col(1).minCoeff()));
    hi = hi.cwiseMax(Eigen::Vector2d(m.V.col(0).maxCoeff(), m.V.col(1).maxCoeff()));
  }
  const double extent = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1e-3});
  cv::Mat img(ph + top, pw * int(meshes.size()), CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Scalar colours[] = {{70, 130, 180}, {60, 60, 220}, {60, 160, 60}};
  for (size_t i = 0; i < meshes.size(); ++i) {
    cv::Mat panel = img(cv::Rect(int(i) * pw, top, pw, ph));
    OrthoView v;
    v.width = pw, v.height = ph, v.scale = 0.9 * std::min(pw, ph) / extent;
    v.cx = 0, v.cy = (lo.y() + hi.y()) / 2;
    DrawShadedMesh(panel, meshes[i], v, colours[i % 3]);
    std::istringstream lines(captions[i]);
    std::string line;
    for (int k = 0; std::getline(lines, line) && k < 2; ++k)
      cv::putText(img, line.substr(0, 40), {int(i) * pw + 4, 16 + 16 * k}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1,
                  cv::LINE_AA);
  }
  std::vector<uchar> png;
  cv::imencode(".png", img, png);
  WriteFileAtomic(path, std::string(png.begin(), png.end()));
}

std::string Safe(const std::string& s) {
  std::string o;
  for (char c : s) o += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return o;
}

}  // namespace

Json WriteWorstConfusions(const Release& release, const Database& db, const std::vector<LadderResult>& results,
                          const fs::path& dir, int per_category) {
  Json out = Json::array();
  for (const auto& lr : results) {
    std::map<std::string, std::vector<const Json*>> wrong;
    for (const Json& q : lr.eval.report["per_query"]) {
      if (!q.contains("category_known")) continue;
      const std::string cat = q["category"];
      auto conf = lr.eval.confusion.find(cat);
      if (conf == lr.eval.confusion.end()) continue;
      const std::string key = "both/" + conf->second.metric;
      if (q["category_known"].contains(key) && !q["category_known"][key]["correct"].get<bool>())
        wrong[cat].push_back(&q);
    }
    for (auto& [cat, qs] : wrong) {
      const std::string key = "both/" + lr.eval.confusion.at(cat).metric;
      std::stable_sort(qs.begin(), qs.end(), [&](const Json* a, const Json* b) {
        return (*a)["category_known"][key]["distance"].get<double>() <
               (*b)["category_known"][key]["distance"].get<double>();
      });
      const size_t shown = std::min<size_t>(std::max(per_category, 0), qs.size());
      for (size_t k = 0; k < shown; ++k) {
        const Json& q = *qs[k];
        const Json& m = q["category_known"][key];
        const std::string matched = m["entry"];
        // The true database entry: the query's anchor, preferably on the matched instance.
        std::string truth, matched_instance;
        for (int i : db.EntriesOf(cat))
          if (db.label(i).id == matched) matched_instance = db.label(i).instance;
        for (int i : db.EntriesOf(cat)) {
          const EntryLabel& l = db.label(i);
          if (l.anchor != q["anchor"].get<std::string>()) continue;
          if (truth.empty() || l.instance == matched_instance) truth = l.id;
        }
        std::vector<TriMesh> meshes;
        std::vector<std::string> captions = {
            "query " + q["anchor"].get<std::string>() + "\n" + q["id"].get<std::string>(),
            "matched " + m["anchor"].get<std::string>() + " (d " + std::to_string(m["distance"].get<int>()) + ")\n" +
                matched,
            "true " + q["anchor"].get<std::string>() + "\n" + truth};
        for (const std::string& id : {q["id"].get<std::string>(), matched, truth}) {
          try {
            meshes.push_back(id.empty() ? TriMesh() : ReadMesh(release.EntryPath(id, "recon.ply")));
          } catch (const Error&) {
            meshes.push_back(TriMesh());
          }
        }
        const std::string name = "ladder_" + Safe(lr.rung.split) + "_" + Safe(cat) + "_" + std::to_string(k) + ".png";
        DrawTriptych(meshes, captions, dir / name);
        out.push_back({{"file", name},
                       {"split", lr.rung.split},
                       {"category", cat},
                       {"query", q["id"]},
                       {"matched", matched},
                       {"truth", truth},
                       {"metric", key}});
      }
    }
  }
  return out;
}

}  // namespace drape::recognition
