// The dataset card (README.md) and the gallery (index.html) of a release.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "generator/release/release_internal.h"

namespace drape::release_detail {
namespace {

std::string YamlString(const std::string& s) {
  // JSON strings are valid YAML double-quoted scalars.
  return Json(s).dump();
}

std::string Html(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Str(const Json& r, const char* k) {
  return r.is_object() && r.contains(k) && r[k].is_string() ? r[k].get<std::string>() : std::string();
}

// Fusion error (recon→truth mean, metres) if the record has it.
bool FusionError(const Json& r, double* v) {
  if (!r.is_object() || !r.contains("fusion") || !r["fusion"].is_object()) return false;
  const Json& f = r["fusion"];
  const Json* x = nullptr;
  if (f.contains("recon_to_truth_mean"))
    x = &f["recon_to_truth_mean"];
  else if (f.contains("accuracy") && f["accuracy"].is_object() && f["accuracy"].contains("recon_to_truth_mean"))
    x = &f["accuracy"]["recon_to_truth_mean"];
  if (!x || !x->is_number()) return false;
  *v = x->get<double>();
  return std::isfinite(*v);
}

std::string SizeCategory(size_t n) {
  if (n < 1000) return "n<1K";
  if (n < 10000) return "1K<n<10K";
  if (n < 100000) return "10K<n<100K";
  return "100K<n<1M";
}

// Number at record path a.b (or NaN).
double Num(const Json& r, const char* a, const char* b) {
  if (!r.is_object() || !r.contains(a) || !r[a].is_object() || !r[a].contains(b) || !r[a][b].is_number())
    return std::nan("");
  return r[a][b].get<double>();
}

std::string Fmt(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

// The hung meshes as measured by the build (record "hang"): self-intersections by
// CGAL's exact test, clearance, edge strain against each material's stretch; and the
// material fits (record "material_fit"). Empty when no entry has these fields.
std::string SimulationQuality(const std::vector<Release::EntryInfo>& entries) {
  int measured = 0, intersecting = 0;
  double min_dist = INFINITY, worst_max = 0, worst_p99 = 0, worst_max_rel = 0, worst_p99_rel = 0;
  std::vector<double> medians_rel, com_offsets;
  std::map<std::string, const Json*> fits;
  for (const auto& e : entries) {
    if (e.failed) continue;
    const Json& r = e.record;
    const double pairs = Num(r, "hang", "intersecting_pairs");
    if (std::isnan(pairs)) continue;
    ++measured;
    intersecting += pairs > 0;
    min_dist = std::min(min_dist, Num(r, "hang", "min_distance"));
    const double stretch = Num(r, "material_values", "stretch_percent") / 100;
    const double mx = Num(r, "hang", "strain_max"), p99 = Num(r, "hang", "strain_p99");
    worst_max = std::max(worst_max, mx);
    worst_p99 = std::max(worst_p99, p99);
    if (stretch > 0) {
      worst_max_rel = std::max(worst_max_rel, mx / stretch);
      worst_p99_rel = std::max(worst_p99_rel, p99 / stretch);
      medians_rel.push_back(Num(r, "hang", "strain_median") / stretch);
    }
    if (const double c = Num(r, "hang", "com_offset"); !std::isnan(c)) com_offsets.push_back(c);
    const std::string mat = Str(r, "material");
    if (!mat.empty() && r.contains("material_fit") && r["material_fit"].is_object()) fits[mat] = &r["material_fit"];
  }
  if (measured == 0) return "";
  std::ostringstream o;
  o << "\n## Simulation quality\n\n";
  o << "Hung meshes of the published entries as the build measured them (an entry whose mesh "
       "intersects itself, breaks the strain bounds or never settled is failed, not published):\n\n";
  o << "- intersecting triangle pairs (CGAL exact test): " << intersecting << " of " << measured
    << " meshes intersect themselves\n";
  o << "- smallest distance between non-adjacent elements: " << Fmt(1000 * min_dist, 3) << " mm\n";
  o << "- edge strain, worst entry: max " << Fmt(100 * worst_max, 2) << " % (" << Fmt(worst_max_rel, 2)
    << " × its material's stretch), p99 " << Fmt(100 * worst_p99, 2) << " % (" << Fmt(worst_p99_rel, 2) << " ×)\n";
  if (!medians_rel.empty()) {
    std::sort(medians_rel.begin(), medians_rel.end());
    o << "- median edge strain / material stretch, median over entries: " << Fmt(medians_rel[medians_rel.size() / 2], 2)
      << "\n";
  }
  if (!com_offsets.empty()) {
    std::sort(com_offsets.begin(), com_offsets.end());
    o << "- centre of mass beside the grasp point (horizontal; 0 for a grip that carries no moment): median "
      << Fmt(100 * com_offsets[com_offsets.size() / 2], 1) << " cm, max " << Fmt(100 * com_offsets.back(), 1)
      << " cm\n";
  }
  if (!fits.empty()) {
    o << "\n| material | stretch % measured | reproduced | friction angle ° measured | reproduced | μ (sim) |\n"
         "|---|---|---|---|---|---|\n";
    for (const auto& [name, f] : fits) {
      // fit = f: clang 14 cannot capture a structured binding.
      auto val = [fit = f](const char* k) {
        return fit->contains(k) && (*fit)[k].is_number() ? (*fit)[k].get<double>() : NAN;
      };
      o << "| " << name << " | " << Fmt(val("target_stretch_percent"), 2) << " | "
        << Fmt(val("reproduced_stretch_percent"), 3) << " | " << Fmt(val("target_friction_deg"), 1) << " | "
        << Fmt(val("reproduced_friction_deg"), 2) << " | " << Fmt(val("friction"), 3) << " |\n";
    }
  }
  return o.str();
}

// What the card counts: entries per split, per category, per split × category and
// per anchor label, and the failed entries. Passed mutable: the writers read it with
// operator[] as the card always did.
struct CardCounts {
  std::vector<std::string> splits;
  std::map<std::string, int> split_n, cat_n, anchor_n;
  std::map<std::string, std::map<std::string, int>> sc;
  std::vector<const Release::EntryInfo*> failed;
};

CardCounts CountEntries(const std::vector<Release::EntryInfo>& entries) {
  CardCounts c;
  c.splits = OrderedSplits(entries);
  for (const auto& e : entries) {
    ++c.split_n[e.split];
    ++c.cat_n[Category(e)];
    ++c.sc[e.split][Category(e)];
    const std::string a = AnchorLabel(e);
    if (!a.empty()) ++c.anchor_n[a];
    if (e.failed) c.failed.push_back(&e);
  }
  return c;
}

// The Hugging Face YAML front matter.
void CardFrontMatter(std::ostream& o, const Json& ds, const std::vector<Release::EntryInfo>& entries, CardCounts& c) {
  o << "---\n";
  o << "pretty_name: " << YamlString("drape " + ds.value("name", "") + " " + ds.value("version", "")) << "\n";
  {
    // HF wants an identifier (cc-by-4.0, mit, other); quote anything else.
    const std::string lic = ds.value("license", std::string("other"));
    bool simple = !lic.empty();
    for (char c : lic) simple = simple && (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '.');
    o << "license: " << (simple ? lic : YamlString(lic)) << "\n";
  }
  o << "task_categories:\n- robotics\n- depth-estimation\n";
  o << "tags:\n- synthetic\n- garments\n- deformable-objects\n- cloth\n- depth\n- sdf\n";
  o << "size_categories:\n- " << SizeCategory(entries.size()) << "\n";
  o << "dataset_info:\n  splits:\n";
  for (const auto& s : c.splits) o << "  - name: " << s << "\n    num_examples: " << c.split_n[s] << "\n";
  o << "---\n\n";
}

// "## Contents": entries per split × category, grasp points, failed entries.
void CardContents(std::ostream& o, const std::vector<Release::EntryInfo>& entries, CardCounts& c) {
  o << "## Contents\n\n";
  o << entries.size() << " entries, " << c.failed.size() << " failed.\n\n";
  o << "| split | entries |";
  std::vector<std::string> cats;
  for (const auto& [cat, n] : c.cat_n) cats.push_back(cat);
  for (const auto& cat : cats) o << " " << cat << " |";
  o << "\n|---|---|";
  for (size_t i = 0; i < cats.size(); ++i) o << "---|";
  o << "\n";
  for (const auto& s : c.splits) {
    o << "| " << s << " | " << c.split_n[s] << " |";
    for (const auto& cat : cats) o << " " << c.sc[s][cat] << " |";
    o << "\n";
  }
  if (!c.anchor_n.empty()) {
    o << "\nGrasp points (anchor label: entries): ";
    bool first = true;
    for (const auto& [a, n] : c.anchor_n) {
      o << (first ? "" : ", ") << "`" << a << "`: " << n;
      first = false;
    }
    o << ".\n";
  }
  if (!c.failed.empty()) {
    o << "\nFailed entries (kept in the catalog with their reason):\n\n";
    for (const auto* e : c.failed) o << "- `" << e->id << "`: " << e->failure << "\n";
  }
}

// The recipe summary (dataset.json "summary"), if any.
void CardSummary(std::ostream& o, const Json& ds) {
  if (ds.contains("summary") && ds["summary"].is_object() && !ds["summary"].empty()) {
    o << "\n## Recipe summary\n\n";
    for (auto it = ds["summary"].begin(); it != ds["summary"].end(); ++it) {
      o << "- **" << it.key() << "**: " << (it.value().is_string() ? it.value().get<std::string>() : it.value().dump())
        << "\n";
    }
  }
}

// "## Layout" and "## Verify and rebuild": fixed text.
void CardLayout(std::ostream& o) {
  o << "\n## Layout\n\n"
       "- `dataset.json`: name, version, seed, recipe (full text + SHA-256), code version, counts, digest.\n"
       "- `catalog.sqlite`: table `entries` (one row per entry; record fields as columns, "
       "`record_json`, `files_json`, packed features as BLOBs), `files`, `jobs`, `meta`.\n"
       "- `entries/<id>/`: `entry.json` and the entry's files (`hang.ply` stationary mesh in the "
       "object frame — gripper at the origin, y up —, `recon.ply`, `sdf.vdb`, `feature.bin`, "
       "`preview.png`, optionally `sweep/` 16-bit depth PNGs in mm + `cameras.json`).\n"
       "- `index.html`: a gallery to open in a browser.\n"
       "- `viewer/`: the gallery's 3D view: three.js (MIT, `LICENSE.three.txt`) and each entry's "
       "hang.ply + recon.ply as a script `viewer/meshes/<id>.js` (pages opened from file:// may load "
       "scripts but not read files); outside the release digest.\n"
       "- `SHA256SUMS`: hashes of every file; `build.json`: build times (not hashed); `calibration/`: learned weights "
       "written by `drape calibrate` (bound to the digest, not hashed).\n";
  o << "\n## Verify and rebuild\n\n```sh\nsha256sum -c SHA256SUMS        # files\n"
       "drape verify .                  # files + release digest\n"
       "drape verify . --rebuild        # rebuild from the recipe and compare entry by entry\n"
       "# or by hand: the full recipe is in dataset.json\n"
       "python3 -c \"import json;print(json.load(open('dataset.json'))['recipe']['text'],end='')\" > recipe.yaml\n"
       "drape build recipe.yaml -o /tmp/rebuilt && drape verify /tmp/rebuilt --published .\n```\n";
}

// "## Provenance", the full recipe and the citation.
void CardProvenance(std::ostream& o, const Json& ds) {
  o << "\n## Provenance\n\n";
  o << "- release digest: `" << ds.value("digest", "") << "`\n";
  o << "- seed: " << ds.value("seed", Json()).dump() << "\n";
  o << "- recipe sha256: `" << ds["recipe"].value("sha256", "") << "`\n";
  o << "- code version: `" << ds.value("code_version", "") << "`\n";
  if (ds.contains("shard")) o << "- shard: " << ds["shard"].dump() << "\n";
  o << "\n<details><summary>Recipe</summary>\n\n```yaml\n" << ds["recipe"].value("text", "");
  const std::string rt = ds["recipe"].value("text", "");
  if (!rt.empty() && rt.back() != '\n') o << "\n";
  o << "```\n\n</details>\n";
  o << "\n## Citation\n\n```bibtex\n@inproceedings{li2015model,\n"
       "  title={Model-Driven Feed-Forward Prediction for Manipulation of Deformable Objects},\n"
       "  author={Li, Yinxiao and Wang, Yan and Yue, Yonghao and Xu, Danfei and Case, Michael and "
       "Chang, Shih-Fu and Grinspun, Eitan and Allen, Peter K.},\n  year={2015}\n}\n```\n";
}

}  // namespace

std::string DatasetCard(const Json& ds, const std::vector<Release::EntryInfo>& entries) {
  const std::string name = ds.value("name", ""), version = ds.value("version", "");
  CardCounts counts = CountEntries(entries);
  std::ostringstream o;
  CardFrontMatter(o, ds, entries, counts);
  o << "# " << name << " " << version << "\n\n";
  const std::string desc = ds.value("description", "");
  if (!desc.empty()) o << desc << "\n\n";
  o << "Simulated garments hanging in their stationary state from labelled grasp points, "
       "with synthetic Kinect depth sweeps, fused signed distance fields, reconstructed meshes "
       "and the binary cylindrical shape feature of Li et al., *Model-Driven Feed-Forward "
       "Prediction for Manipulation of Deformable Objects*. Generated by `drape` from the recipe "
       "below; every entry is one garment instance × material × grasp point.\n\n";
  CardContents(o, entries, counts);
  o << SimulationQuality(entries);
  CardSummary(o, ds);
  CardLayout(o);
  CardProvenance(o, ds);
  return o.str();
}

namespace {

// The page head (title, styles) and the split and category filters.
void GalleryHead(std::ostream& o, const Json& ds, const std::vector<Release::EntryInfo>& entries) {
  const std::string title = ds.value("name", "") + " " + ds.value("version", "");
  std::set<std::string> cats;
  for (const auto& e : entries) cats.insert(Category(e));
  o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
    << "<title>" << Html(title) << "</title>\n"
    << "<style>\n"
       "body{font-family:sans-serif;margin:1em;background:#fafafa}\n"
       "#grid{display:flex;flex-wrap:wrap;gap:10px}\n"
       ".card{width:330px;background:#fff;border:1px solid #ccc;border-radius:6px;padding:6px;font-size:12px}\n"
       ".card img{width:330px;height:150px;object-fit:contain;background:#eee}\n"
       ".card "
       ".noimg{width:330px;height:150px;background:#eee;display:flex;align-items:center;justify-content:center;color:#"
       "888}\n"
       ".card.failed{border-color:#c33}\n.card .fail{color:#c33}\n"
       ".card b{font-size:13px}\n"
       ".card button.v3d{float:right;font-size:12px}\n"
       "#v3d{position:fixed;inset:0;background:#fff;z-index:10;display:flex;flex-direction:column;font-size:13px}\n"
       "#v3d-bar{padding:6px;border-bottom:1px solid #ccc}\n"
       "#v3d-labels{display:flex;color:#555}\n#v3d-labels span{flex:1;text-align:center}\n"
       "#v3d-canvas{flex:1;width:100%;min-height:0;display:block}\n"
       "</style>\n</head>\n<body>\n";
  o << "<h1>" << Html(title) << "</h1>\n";
  o << "<p>" << entries.size() << " entries · digest <code>" << Html(ds.value("digest", "")) << "</code></p>\n";
  o << "<p><label>split <select id=\"split\"><option value=\"\">all</option>";
  for (const auto& s : OrderedSplits(entries)) o << "<option>" << Html(s) << "</option>";
  o << "</select></label> <label>category <select id=\"category\"><option value=\"\">all</option>";
  for (const auto& c : cats) o << "<option>" << Html(c) << "</option>";
  o << "</select></label> showing <span id=\"shown\">" << entries.size() << "</span> of " << entries.size()
    << " <span id=\"ready\"></span></p>\n";
}

// One entry's card: preview, 3D view button, split, garment, material, anchor, fusion error.
void GalleryCard(std::ostream& o, const Release::EntryInfo& e) {
  const std::string cat = Category(e);
  bool has_preview = false;
  for (const auto& f : e.files) has_preview = has_preview || f.path == "preview.png";
  o << "<div class=\"card" << (e.failed ? " failed" : "") << "\" data-split=\"" << Html(e.split)
    << "\" data-category=\"" << Html(cat) << "\">";
  if (has_preview) {
    o << "<a href=\"entries/" << Html(e.id) << "/\"><img loading=\"lazy\" src=\"entries/" << Html(e.id)
      << "/preview.png\" alt=\"" << Html(e.id) << "\"></a>";
  } else {
    o << "<div class=\"noimg\">no preview</div>";
  }
  // The 3D view (viewer/drape-viewer.js): hung and fused mesh side by side.
  if (EntryHas3d(e)) o << "<button class=\"v3d\" data-id=\"" << Html(e.id) << "\">3D view</button>";
  o << "<br><b>" << Html(e.id) << "</b><br>split: " << Html(e.split) << "<br>garment: " << Html(cat);
  const std::string inst = Str(e.record, "instance"), garment = Str(e.record, "garment");
  if (!inst.empty())
    o << " / " << Html(inst);
  else if (!garment.empty())
    o << " / " << Html(garment);
  const std::string mat = Str(e.record, "material");
  if (!mat.empty()) o << "<br>material: " << Html(mat);
  const std::string a = AnchorLabel(e);
  o << "<br>anchor: " << (a.empty() ? "–" : Html(a));
  double err;
  if (FusionError(e.record, &err)) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.2f mm", err * 1000);
    o << "<br>fusion error: " << buf;
  }
  if (e.failed) o << "<br><span class=\"fail\">failed: " << Html(e.failure) << "</span>";
  o << "</div>\n";
}

// The filter script (and the 3D viewer's, if the release has one); closes the page.
void GalleryScript(std::ostream& o) {
  // Plain inline JS: filters, also settable as index.html#split=test&category=shirt.
  if (GalleryHas3d()) o << "<script src=\"viewer/drape-viewer.js\"></script>\n";
  o << "<script>\n"
       "(function(){\n"
       "  var sp=document.getElementById('split'), ca=document.getElementById('category');\n"
       "  function apply(){\n"
       "    var n=0, cards=document.querySelectorAll('.card');\n"
       "    for(var i=0;i<cards.length;i++){\n"
       "      var c=cards[i], ok=(!sp.value||c.getAttribute('data-split')===sp.value)&&\n"
       "        (!ca.value||c.getAttribute('data-category')===ca.value);\n"
       "      c.style.display=ok?'':'none'; if(ok) n++;\n"
       "    }\n"
       "    document.getElementById('shown').textContent=String(n);\n"
       "  }\n"
       "  var h=location.hash.replace(/^#/,'').split('&');\n"
       "  for(var i=0;i<h.length;i++){var kv=h[i].split('=');\n"
       "    if(kv[0]==='split') sp.value=decodeURIComponent(kv[1]||'');\n"
       "    if(kv[0]==='category') ca.value=decodeURIComponent(kv[1]||'');\n"
       "    if(kv[0]==='view'&&window.drapeOpen3d) window.drapeOpen3d(decodeURIComponent(kv[1]||''));}\n"
       "  var b=document.querySelectorAll('button.v3d');\n"
       "  for(var i=0;i<b.length;i++) "
       "b[i].addEventListener('click',function(){window.drapeOpen3d(this.getAttribute('data-id'));});\n"
       "  sp.addEventListener('change',apply); ca.addEventListener('change',apply);\n"
       "  apply(); document.getElementById('ready').textContent='(filters ready)';\n"
       "})();\n"
       "</script>\n</body>\n</html>\n";
}

}  // namespace

std::string Gallery(const Json& ds, const std::vector<Release::EntryInfo>& entries) {
  std::ostringstream o;
  GalleryHead(o, ds, entries);
  o << "<div id=\"grid\">\n";
  for (const auto& e : entries) GalleryCard(o, e);
  o << "</div>\n";
  GalleryScript(o);
  return o.str();
}

}  // namespace drape::release_detail
