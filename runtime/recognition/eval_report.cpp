// The report of `drape eval`: report.json, report.md (the paper's tables, the
// registration table, the ladder) and the plots (accuracy.png, confusion_<category>.png).
// Evaluate (evaluate.cpp) scores and aggregates; this file only presents its result.
#include <algorithm>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/error.h"
#include "common/files.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/k_curve.h"
#include "runtime/recognition/ladder.h"
#include "runtime/recognition/miss_curve.h"
#include "runtime/recognition/report_format.h"

namespace drape::recognition {

namespace fs = std::filesystem;

namespace {

std::string Num(const Json& v, const char* fmt = "%.3f") {
  if (v.is_null()) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, fmt, v.get<double>());
  return buf;
}

std::string Pair(const Json& obj) { return PercentCell(obj["unweighted"]) + " / " + PercentCell(obj["learned"]); }

// The paper's pose table: one column per database instance, the paper's two, all.
std::string PoseTableMarkdown(const Json& r, const std::vector<Json>& rows) {
  std::ostringstream md;
  // Instance columns: as many as the category with the most instances has (at least 2, as
  // the paper); with more than 2 also the paper's database (instances 1–2), and the
  // all-instances column (JSON key "both") is headed "all".
  const Json& overall = r["overall"]["pose_accuracy"];
  int columns = 0;
  while (overall.contains("instance" + std::to_string(columns + 1))) ++columns;
  const bool more = overall.contains("instances1_2");
  const std::string all_name = more ? "all" : "both";
  md << "## Pose accuracy, category known (unweighted Eq. match / learned Eq. bestmatch)\n\n";
  if (more) {
    md << "Correct anchor / all queries, using only database instance 1, only instance 2, … (instances sorted by "
          "name), the first two together (the paper's database: two models per garment type) or all of the "
          "category's instances. Paper (real Kinect data, learned distance) in the last column.\n\n";
  } else {
    md << "Correct anchor / all queries, using only database instance 1, only instance 2, or both "
          "(instances sorted by name). Paper (real Kinect data, learned distance) in the last column.\n\n";
  }
  md << "The learned columns cover the categories that have weights (" << (more ? "the \"all\" row" : "\"all\"")
     << " too); n/a = no such database instance or no weights.\n\n| category | queries";
  for (int i = 1; i <= columns; ++i) md << " | instance " << i;
  md << (more ? " | instances 1–2" : "") << " | " << all_name << " | paper: 1 / 2 / both |\n|---|---";
  for (int i = 0; i < columns + (more ? 3 : 2); ++i) md << "|---";
  md << "|\n";
  for (const Json& c : rows) {
    const Json& p = c["pose_accuracy"];
    std::string paper = "—";
    if (!c["paper"].is_null()) {
      paper = PercentCell(c["paper"]["instance1"]) + " / " + PercentCell(c["paper"]["instance2"]) + " / " +
              PercentCell(c["paper"]["both"]);
    }
    std::string names;
    for (const auto& n : c["database_instances"]) names += (names.empty() ? "" : ", ") + n.get<std::string>();
    md << "| " << c["category"].get<std::string>() << (names.empty() ? "" : " (" + names + ")") << " | "
       << c["queries"].get<int>();
    for (int i = 1; i <= columns; ++i) md << " | " << Pair(p["instance" + std::to_string(i)]);
    if (more) md << " | " << Pair(p["instances1_2"]);
    md << " | " << Pair(p["both"]) << " | " << paper << " |\n";
  }
  return md.str();
}

// "5 / 19: 26.3 % (11.8–48.8 %)" of a precision figure ("n/a" for null).
std::string IntervalCell(const Json& f) {
  if (f.is_null()) return "n/a";
  char buf[96];
  std::snprintf(buf, sizeof buf, "%d / %d: %.1f %% (%.1f–%.1f %%)", f["correct"].get<int>(), f["n"].get<int>(),
                100.0 * f["correct"].get<int>() / f["n"].get<int>(), 100 * f["low"].get<double>(),
                100 * f["high"].get<double>());
  return buf;
}

// report.json's "precision" of every row: the intervals, and what a second run must show.
std::string PrecisionMarkdown(const std::vector<Json>& rows) {
  std::ostringstream md;
  md << "## How precise these figures are\n\n"
     << "Each figure is k of n queries (both database instances, the runtime's distance; category by the "
        "unweighted nearest neighbour), with its 95 % Wilson interval. \"Beyond chance\": the difference in "
        "strict pose that another run of the same size (another recipe seed, another build) must show before it "
        "is more than chance (two-sided 5 %), and the queries per run that a 5-point difference would need.\n\n"
     << "| category | strict pose | twin credited | category | beyond chance | queries for 5 points |\n"
     << "|---|---|---|---|---|---|\n";
  for (const Json& c : rows) {
    const Json& p = c["precision"];
    md << "| " << c["category"].get<std::string>() << " | " << IntervalCell(p["strict"]) << " | "
       << IntervalCell(p["twin_credited"]) << " | " << IntervalCell(p["category"]) << " | ";
    if (p.contains("strict_difference_beyond_chance")) {
      md << "±" << Num(Json(100 * p["strict_difference_beyond_chance"].get<double>()), "%.1f") << " points | "
         << p["strict_queries_for_5_points"].get<int>() << " |\n";
    } else {
      md << "n/a | n/a |\n";
    }
  }
  return md.str();
}

}  // namespace

std::string RegistrationMarkdown(const Json& t) {
  std::ostringstream md;
  auto d = [](const Json& v) { return Num(v, "%.4f"); };
  md << "## Registration (pose known), split " << t.value("split", "?") << "\n\n"
     << "Source S = the database mesh (train entry's hang.ply) of the test entry's true category and anchor; "
     << "target T = the test entry's reconstruction (recon.ply), full resolution. Paper's metric: one sample per "
     << "triangle of the measured-from mesh, area-weighted mean distance to the other mesh, metres. "
     << "Anchor error: transferred database anchor vertex vs the true anchor vertex on the test entry's hung mesh, "
     << "cm (both in the object frame). Rows: category / test garment instance.\n\n"
     << "| garment | pairs | S→T (R) | T→S (R) | S→T (R+N) | T→S (R+N) | anchor cm, mean (R / R+N) | "
        "anchor cm, median (R / R+N) | s per registration |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  auto row = [&](const Json& g, bool bold) {
    const std::string b = bold ? "**" : "";
    md << "| " << b << g.value("garment", "") << b << " | " << g.value("pairs", 0) << " | " << d(g["s_to_t_rigid"])
       << " | " << d(g["t_to_s_rigid"]) << " | " << d(g["s_to_t_nonrigid"]) << " | " << d(g["t_to_s_nonrigid"]) << " | "
       << Num(g["anchor_error_cm"]["rigid"], "%.1f") << " / " << Num(g["anchor_error_cm"]["nonrigid"], "%.1f") << " | "
       << Num(g["anchor_error_cm"].value("rigid_median", Json()), "%.1f") << " / "
       << Num(g["anchor_error_cm"].value("nonrigid_median", Json()), "%.1f") << " | "
       << Num(g["timing"]["seconds_per_registration"], "%.2f") << " |\n";
  };
  for (const Json& g : t.value("garments", Json::array())) row(g, false);
  if (t.contains("average")) row(t["average"], true);
  if (t.contains("paper")) {
    const Json& p = t["paper"];
    md << "\nPaper (real Kinect data):\n\n| garment | S→T (R) | T→S (R) | S→T (R+N) | T→S (R+N) "
          "|\n|---|---|---|---|---|\n";
    std::vector<Json> rows(p["rows"].begin(), p["rows"].end());
    rows.push_back(p["average"]);
    for (const Json& g : rows) {
      md << "| " << g.value("garment", "") << " | " << d(g["s_to_t_rigid"]) << " | " << d(g["t_to_s_rigid"]) << " | "
         << d(g["s_to_t_nonrigid"]) << " | " << d(g["t_to_s_nonrigid"]) << " |\n";
    }
  }
  if (t.contains("average")) {
    const Json& tm = t["average"]["timing"];
    md << "\nTime per registration (mean, s): grid " << Num(tm["grid_seconds"]) << ", ICP " << Num(tm["icp_seconds"])
       << ", non-rigid " << Num(tm["nonrigid_seconds"]) << ", total " << Num(tm["seconds_per_registration"])
       << "; whole table " << Num(t["timing"]["wall_seconds"], "%.1f") << " s wall on "
       << t["timing"].value("threads", 0) << " threads.\n";
  }
  int recognised = 0, first = 0, offsets = 0;
  std::vector<double> from_grasp;
  for (const Json& p : t.value("pairs", Json::array())) {
    if (p.contains("anchor_truth_from_grasp_cm")) from_grasp.push_back(p["anchor_truth_from_grasp_cm"].get<double>());
    (p.value("source_choice", "") == "recognised" ? recognised : first) += 1;
  }
  if (!from_grasp.empty()) {
    std::sort(from_grasp.begin(), from_grasp.end());
    for (double d : from_grasp) offsets += d > 10;
    md << "\nThe true anchors lie " << Num(Json(from_grasp[from_grasp.size() / 2]), "%.1f")
       << " cm (median) from the grip (test entries are hung with a grasp offset; database anchors are at the "
          "grip): a transferred anchor at the grip would be off by this much";
    if (offsets > 0) md << "; " << offsets << " pair(s) have their true anchor > 10 cm from the grip";
    md << ".\n";
  }
  md << "\nSource instance: " << recognised << " pairs use the entry recognition matched (right anchor), " << first
     << " the first database instance with the true anchor.";
  if (t.contains("average") && t["average"].value("pairs_with_warnings", 0) > 0) {
    md << " Pairs whose registration warned (e.g. ICP not converged; report.json has each): "
       << t["average"]["pairs_with_warnings"].get<int>() << ".";
  }
  if (t.value("failed", 0) > 0) md << " Failed registrations: " << t["failed"].get<int>() << ".";
  if (t.value("limited_out", 0) > 0)
    md << " Left out by eval.registration_pairs: " << t["limited_out"].get<int>() << ".";
  md << "\n";
  for (const Json& s : t.value("skipped", Json::array())) {
    md << "- skipped " << s.value("id", "") << ": " << s.value("reason", "") << "\n";
  }
  return md.str();
}

namespace {

// report.json "category_fit" row of `category`, or null.
Json FitRow(const Json& r, const std::string& category) {
  if (!r.contains("category_fit")) return nullptr;
  for (const Json& c : r["category_fit"]["categories"]) {
    if (c["category"] == category) return c;
  }
  return nullptr;
}

// `drape eval --category-fit` (category_fit.h): its table, and the selection's when run.
std::string CategoryFitMarkdown(const Json& r) {
  std::ostringstream md;
  if (r.contains("category_fit")) {
    const Json& f = r["category_fit"];
    const Json& o = f["options"];
    md << "\n## Category by registration (on by default; `--no-category-fit` skips it)\n\n"
       << "Per query the " << o["per_category"].get<int>() << " best entr"
       << (o["per_category"].get<int>() == 1 ? "y" : "ies") << " (Hamming) of "
       << (o["top_categories"].get<int>() > 0
               ? "each of the " + std::to_string(o["top_categories"].get<int>()) + " nearest categories"
               : std::string("each category"))
       << " through the category gate τ = " << Num(f["category_gate"], "%.2f")
       << ": hang.ply turned by the matched rotation, registered (scale + ICP) onto recon.ply; the category of "
          "the least symmetric mean surface distance (score = fit / least fit + λ · bits / least bits, λ = "
       << Num(o["bits_weight"], "%.2f") << "). End to end: right category and anchor (u / l).\n\n"
       << "| category | queries | category, unweighted NN / registration | end to end, NN (u / l) | end to end, "
          "registration (u / l) | s per query |\n|---|---|---|---|---|---|\n";
    for (const Json& c : f["categories"]) {
      md << "| " << c["category"].get<std::string>() << " | " << c["queries"].get<int>() << " | "
         << PercentCell(c["category_accuracy"]["unweighted_nn"]) << " / "
         << PercentCell(c["category_accuracy"]["registration"]) << " | "
         << Pair(c["end_to_end_pose_accuracy"]["unweighted_nn"]) << " | "
         << Pair(c["end_to_end_pose_accuracy"]["registration"]) << " | " << Num(c["seconds_per_query"], "%.2f")
         << " |\n";
    }
    md << "\nSeconds per query: reading the reconstruction, registering and measuring, one thread each ("
       << f["threads"].get<int>() << " queries in parallel).\n";
  }
  if (r.contains("category_fit_selection")) {
    const Json& s = r["category_fit_selection"];
    md << "\n## Category by registration: selection on train + calibration (`eval.category_fit_selection`)\n\n"
       << s["queries"].get<int>() << " queries (calibration split, and train entries against the other "
       << "instances; " << s["left_out"].get<int>() << " train entries left out: no other instance of their "
       << "category). Unweighted nearest neighbour: " << s["nearest_neighbour"]["right"].get<int>() << " right.\n\n"
       << "| per category | categories | λ | right |\n|---|---|---|---|\n";
    for (const Json& g : s["grid"]) {
      const Json& o = g["options"];
      md << "| " << o["per_category"].get<int>() << " | "
         << (o["top_categories"].get<int>() > 0 ? std::to_string(o["top_categories"].get<int>()) : std::string("all"))
         << " | " << Num(o["bits_weight"], "%.2f") << " | " << g["right"].get<int>() << " |\n";
    }
    if (!s["chosen"].is_null()) {
      md << "\nOne-standard-error rule: per category " << s["chosen"]["per_category"].get<int>() << ", λ "
         << Num(s["chosen"]["bits_weight"], "%.2f") << " (" << s["chosen_right"].get<int>() << " right).\n";
    }
    if (s.contains("nested_leave_one_out")) {
      md << "\nNested leave-one-out of this choice (each query answered by the setting the rule chooses on "
         << "the other queries): " << s["nested_leave_one_out"]["right"].get<int>() << " right.\n";
    }
  }
  return md.str();
}

// The category accuracy cell: with `--category-fit` also the registration's.
std::string CategoryCell(const Json& r, const Json& row) {
  const Json fit = FitRow(r, row["category"].get<std::string>());
  std::string cell = PercentCell(row["category_accuracy"]);
  if (!fit.is_null()) cell += " / " + PercentCell(fit["category_accuracy"]["registration"]);
  return cell;
}

}  // namespace

std::string ReportMarkdown(const Json& r) {
  std::ostringstream md;
  std::vector<Json> rows(r["categories"].begin(), r["categories"].end());
  rows.push_back(r["overall"]);

  md << PoseTableMarkdown(r, rows);
  if (rows.front().contains("precision")) md << "\n" << PrecisionMarkdown(rows);
  if (r.contains("miss_curve") && r["miss_curve"].is_object()) md << "\n" << MissCurveMarkdown(r["miss_curve"]);
  if (r.contains("k_curve") && r["k_curve"].is_object()) md << "\n" << KCurveMarkdown(r["k_curve"]);
  md << "\n## Category, end to end, top-" << r["top_k"].get<int>() << ", grasp-point error\n\n"
     << "Category by the unweighted nearest neighbour over the whole database (and, beside it, by "
        "registration when `--category-fit` ran: section below); end to end = right "
        "category and right anchor (learned: the runtime's distance, learned w where the category has one). "
        "Grasp-point error: distance on the flat pattern of the query's "
        "garment between the predicted and the true anchor, cm (0 when right), both instances.\n\n"
     << "Twin credited: pose accuracy (both instances) counting the anchor's symmetry twins as right "
        "(left/right swapped; for the rectangular towel also top/bottom). Where a garment's front and back "
        "are alike (the towel, the skirt, any template with its front/back difference set to 0) twins hang "
        "as each other turned about the gripper and no rotation-invariant feature can tell them apart; "
        "shirts (lower front neckline) and trousers (higher back waist) differ front to back, as real "
        "garments do.\n\n"
     << "| category | category accuracy" << (r.contains("category_fit") ? " (unweighted NN / registration)" : "")
     << " | end-to-end pose (u / l) | top-" << r["top_k"].get<int>()
     << " (u / l) | grasp error cm (u / l) | pose, twin credited (u / l) |\n|---|---|---|---|---|---|\n";
  for (const Json& c : rows) {
    md << "| " << c["category"].get<std::string>() << " | " << CategoryCell(r, c) << " | "
       << Pair(c["end_to_end_pose_accuracy"]) << " | " << Pair(c["top_k_accuracy"]) << " | "
       << Num(c["grasp_error_cm"]["unweighted_mean"], "%.1f") << " / "
       << Num(c["grasp_error_cm"]["learned_mean"], "%.1f") << " | "
       << Pair(c.value("pose_accuracy_twin_credited", Json{{"unweighted", nullptr}, {"learned", nullptr}})) << " |\n";
  }
  md << CategoryFitMarkdown(r);
  if (r.contains("height_gates")) {
    const Json& g = r["height_gates"];
    md << "\n## Height gates (an addition to the paper's Algorithm 1)\n\n"
       << "Gates chosen by `drape calibrate` on train + calibration queries: category τ = "
       << Num(g["category"], "%.2f") << ", pose τ = " << Num(g["pose"], "%.2f")
       << " (an entry takes part when |ln(h_query / h_entry)| ≤ τ, h the reconstruction's height; 0 = "
          "no gate). The tables above use them; the same queries with Algorithm 1 alone, as the paper:\n\n"
       << "| category | category accuracy, gates / none | pose both (u / l), gates | pose both (u / l), none |\n"
       << "|---|---|---|---|\n";
    for (const Json& c : rows) {
      if (!c.contains("without_height_gates")) continue;
      const Json& n = c["without_height_gates"];
      md << "| " << c["category"].get<std::string>() << " | " << PercentCell(c["category_accuracy"]) << " / "
         << PercentCell(n["category_accuracy"]) << " | " << Pair(c["pose_accuracy"]["both"]) << " | "
         << Pair(n["pose_accuracy_both"]) << " |\n";
    }
  }
  md << "\n## Running time per query (seconds)\n\n"
     << "| category | fusion | feature | matching | total | paper (i7 3.0 GHz) |\n|---|---|---|---|---|---|\n";
  for (const Json& c : rows) {
    const Json& t = c["seconds_per_query"];
    md << "| " << c["category"].get<std::string>() << " | " << Num(t["fusion"]) << " | " << Num(t["feature"]) << " | "
       << Num(t["matching"], "%.6f") << " | " << Num(t["total"]) << " | "
       << (c["paper"].is_null() ? std::string("—") : Num(c["paper"]["seconds"], "%.2f")) << " |\n";
  }
  if (r.contains("ladder") && r["ladder"].is_object()) md << "\n" << LadderMarkdown(r["ladder"]);
  if (r.contains("registration") && r["registration"].is_object())
    md << "\n" << RegistrationMarkdown(r["registration"]);
  if (!r["warnings"].empty()) {
    md << "\n## Warnings\n\n";
    for (const auto& w : r["warnings"]) md << "- " << w.get<std::string>() << "\n";
  }
  return md.str();
}

namespace {

void WriteAccuracyPlot(const Json& r, const fs::path& path) {
  std::vector<Json> rows(r["categories"].begin(), r["categories"].end());
  rows.push_back(r["overall"]);
  const int group = 150, left = 70, top = 50, plot_h = 300;
  const int width = left + group * static_cast<int>(rows.size()) + 40, height = top + plot_h + 90;
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(img, "Pose accuracy, both instances, category known", {left, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.6,
              {0, 0, 0}, 1, cv::LINE_AA);
  for (int p = 0; p <= 100; p += 20) {
    const int y = top + plot_h - plot_h * p / 100;
    cv::line(img, {left, y}, {width - 20, y}, {220, 220, 220}, 1);
    cv::putText(img, std::to_string(p) + "%", {10, y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  }
  const cv::Scalar colors[] = {{180, 130, 70}, {60, 140, 240}, {90, 90, 90}};
  const char* names[] = {"unweighted", "learned", "paper"};
  for (size_t i = 0; i < rows.size(); ++i) {
    const Json& both = rows[i]["pose_accuracy"]["both"];
    const Json vals[] = {both["unweighted"], both["learned"],
                         rows[i]["paper"].is_null() ? Json(nullptr) : rows[i]["paper"]["both"]};
    for (int b = 0; b < 3; ++b) {
      const int x0 = left + group * static_cast<int>(i) + 15 + b * 40;
      if (vals[b].is_null()) {
        cv::putText(img, "n/a", {x0 + 2, top + plot_h - 5}, cv::FONT_HERSHEY_SIMPLEX, 0.35, {0, 0, 0}, 1, cv::LINE_AA);
        continue;
      }
      const double v = vals[b].get<double>();
      const int h = static_cast<int>(std::lround(plot_h * v));
      cv::rectangle(img, {x0, top + plot_h - h}, {x0 + 34, top + plot_h}, colors[b], cv::FILLED);
      char buf[16];
      std::snprintf(buf, sizeof buf, "%.0f", 100 * v);
      cv::putText(img, buf, {x0 + 4, top + plot_h - h - 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1, cv::LINE_AA);
    }
    cv::putText(img, rows[i]["category"].get<std::string>().substr(0, 18),
                {left + group * static_cast<int>(i) + 10, top + plot_h + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 0},
                1, cv::LINE_AA);
  }
  for (int b = 0; b < 3; ++b) {
    const int x = left + 140 * b;
    cv::rectangle(img, {x, height - 35}, {x + 14, height - 21}, colors[b], cv::FILLED);
    cv::putText(img, names[b], {x + 20, height - 22}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  }
  cv::line(img, {left, top + plot_h}, {width - 20, top + plot_h}, {0, 0, 0}, 1);
  std::vector<uchar> png;
  cv::imencode(".png", img, png);
  WriteFileAtomic(path, std::string(png.begin(), png.end()));
}

void WriteConfusionPlot(const std::string& cat, const EvalResult::Confusion& c, const fs::path& path) {
  const int n = static_cast<int>(c.labels.size());
  const int cell = std::max(22, std::min(40, 600 / std::max(n, 1)));
  const int left = 190, top = 75;
  const int width = std::max(left + cell * n + 30, 480), height = top + cell * n + 30;
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(img, cat + " (" + c.metric + " distance, both instances)", {10, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.55,
              {0, 0, 0}, 1, cv::LINE_AA);
  cv::putText(img, "rows: true anchor, columns: predicted", {10, 44}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {80, 80, 80}, 1,
              cv::LINE_AA);
  for (int i = 0; i < n; ++i) {
    int row_total = 0;
    for (int v : c.counts[i]) row_total += v;
    cv::putText(img, std::to_string(i) + " " + c.labels[i].substr(0, 20), {5, top + cell * i + cell / 2 + 5},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0}, 1, cv::LINE_AA);
    cv::putText(img, std::to_string(i), {left + cell * i + cell / 3, top - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0},
                1, cv::LINE_AA);
    for (int j = 0; j < n; ++j) {
      const double f = row_total ? double(c.counts[i][j]) / row_total : 0.0;
      // White → dark blue with the row-normalised share; the diagonal outlined.
      const cv::Scalar col(255 - 100 * f, 255 - 200 * f, 255 - 230 * f);
      const cv::Point p0(left + cell * j, top + cell * i), p1(left + cell * (j + 1), top + cell * (i + 1));
      cv::rectangle(img, p0, p1, col, cv::FILLED);
      cv::rectangle(img, p0, p1, i == j ? cv::Scalar(0, 160, 0) : cv::Scalar(200, 200, 200), i == j ? 2 : 1);
      if (c.counts[i][j]) {
        cv::putText(img, std::to_string(c.counts[i][j]), {p0.x + cell / 3, p0.y + cell / 2 + 5},
                    cv::FONT_HERSHEY_SIMPLEX, 0.4, f > 0.5 ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0), 1,
                    cv::LINE_AA);
      }
    }
  }
  std::vector<uchar> png;
  cv::imencode(".png", img, png);
  WriteFileAtomic(path, std::string(png.begin(), png.end()));
}

std::string SafeName(const std::string& s) {
  std::string o;
  for (char ch : s) o += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_') ? ch : '_';
  return o;
}

}  // namespace

void WriteReport(const EvalResult& result, const Json& header, const fs::path& dir) {
  Json full = header;
  for (const auto& [k, v] : result.report.items()) full[k] = v;
  Json plots = Json::array({"accuracy.png"});
  WriteAccuracyPlot(result.report, dir / "accuracy.png");
  for (const auto& [cat, c] : result.confusion) {
    const std::string name = "confusion_" + SafeName(cat) + ".png";
    WriteConfusionPlot(cat, c, dir / name);
    plots.push_back(name);
  }
  if (result.report.contains("registration")) {
    for (const auto& f : result.report["registration"].value("figures", Json::array())) plots.push_back(f);
  }
  full["plots"] = plots;
  WriteFileAtomic(dir / "report.json", full.dump(2) + "\n");

  std::ostringstream md;
  md << "# Pose recognition report\n\n";
  for (const auto& [k, v] : header.items()) {
    if (v.is_object() || v.is_array() || v.is_null()) continue;  // tables below / report.json
    md << "- **" << k << "**: " << (v.is_string() ? v.get<std::string>() : v.dump()) << "\n";
  }
  md << "- **queries**: " << result.report["queries"] << ", database entries: " << result.report["database"]["entries"]
     << " (kernel " << result.report["database"]["kernel"].get<std::string>()
     << ")\n\nEvery number below comes from this run (report.json has each query).\n\n";
  md << ReportMarkdown(result.report);
  if (header.contains("calibration") && header["calibration"].is_object()) {
    const Json& cal = header["calibration"];
    md << "\n## Calibration (Eq. learn) of the weights used\n\n"
       << "RankSVM, C = " << cal["options"].value("c", 0.0) << ", frame " << cal["options"].value("frame", "?")
       << ", learned on split '" << cal["options"].value("split", "calibration") << "'. Pair accuracy = share of "
       << "(right-anchor, wrong-anchor) database pairs ranked right for the calibration queries.\n\n"
       << "| category | queries | skipped | pairs | pair accuracy u → l | calibration top-1 u → l | nonzero w |\n"
       << "|---|---|---|---|---|---|---|\n";
    for (const auto& c : cal["stats"].value("categories", Json::array())) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "| %s | %d | %d | %lld | %.3f → %.3f | %d → %d | %.1f %% |\n",
                    c.value("category", "").c_str(), c.value("queries", 0), c.value("skipped", 0),
                    c.value("pairs", 0LL), c.value("ranking_accuracy_unweighted", 0.0),
                    c.value("ranking_accuracy_learned", 0.0), c.value("top1_unweighted", 0), c.value("top1_learned", 0),
                    100 * c.value("nonzero_weight_fraction", 0.0));
      md << buf;
    }
    for (const auto& w : cal["stats"].value("warnings", Json::array())) md << "- " << w.get<std::string>() << "\n";
  }
  if (header.contains("load_warnings") && !header["load_warnings"].empty()) {
    md << "\n## Entries skipped while loading\n\n";
    for (const auto& w : header["load_warnings"]) md << "- " << w.get<std::string>() << "\n";
  }
  md << "\n## Plots\n\n![accuracy](accuracy.png)\n\n";
  for (const auto& [cat, c] : result.confusion) {
    md << "![" << cat << "](confusion_" << SafeName(cat) << ".png)\n\n";
  }
  for (const auto& f : result.report.value("ladder_figures", Json::array())) {
    md << "Ladder, " << f.value("split", "") << ", " << f.value("category", "") << ": query " << f.value("query", "")
       << " | matched " << f.value("matched", "") << " | true " << f.value("truth", "") << "\n\n!["
       << f.value("file", "") << "](" << f.value("file", "") << ")\n\n";
  }
  if (result.report.contains("registration")) {
    for (const auto& f : result.report["registration"].value("figures", Json::array())) {
      md << "![" << f.get<std::string>() << "](" << f.get<std::string>() << ")\n\n";
    }
  }
  WriteFileAtomic(dir / "report.md", md.str());
}

}  // namespace drape::recognition
