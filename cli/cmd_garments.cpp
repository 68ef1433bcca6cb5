// drape garments list|make|show: the garment library from the command line.
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli/command.h"
#include "cli/options.h"
#include "common/error.h"
#include "common/files.h"
#include "garments/io.h"
#include "garments/preview.h"
#include "garments/templates.h"
#include "garments/validate.h"

namespace fs = std::filesystem;

namespace drape::cli {
namespace {

struct GarmentsArgs {
  bool params = false;                   // list
  std::string name, output, size = "M";  // make: TEMPLATE; show: FILE
  std::vector<std::string> param;
  TemplateOptions make;
  std::string anchors, preview;  // show (and make's preview)
  ImportOptions show;
};

int List(const GarmentsArgs& args) {
  std::cout << std::left << std::setw(20) << "template" << std::setw(20) << "category" << std::setw(9) << "anchors"
            << "openings\n";
  for (const auto& t : Templates()) {
    std::string openings;
    for (const auto& o : t.openings) openings += (openings.empty() ? "" : ", ") + o;
    std::cout << std::left << std::setw(20) << t.name << std::setw(20) << t.category << std::setw(9)
              << t.anchor_labels.size() << (openings.empty() ? "(none)" : openings) << "\n";
    if (args.params) {
      std::cout << "    " << t.description << "\n";
      for (const auto& p : t.parameters) {
        std::ostringstream os;
        os << std::fixed << std::setprecision(3) << p.small << " / " << p.medium << " / " << p.large
           << (p.angle ? " rad" : " m");
        std::cout << "    " << std::left << std::setw(16) << p.name << std::setw(28) << os.str() << p.description
                  << "\n";
      }
      std::string labels;
      for (const auto& l : t.anchor_labels) labels += (labels.empty() ? "" : " ") + l;
      std::cout << "    anchors: " << labels << "\n";
    }
  }
  return 0;
}

void PrintGarment(const Garment& g, const MeshReport& r) {
  std::cout << std::fixed << std::setprecision(4);
  std::cout << "instance   " << g.instance << "\n"
            << "category   " << g.category << "\n"
            << "vertices   " << r.vertices << "\n"
            << "faces      " << r.faces << "\n"
            << "size       " << r.bounds_max.x() - r.bounds_min.x() << " x " << r.bounds_max.y() - r.bounds_min.y()
            << " x " << r.bounds_max.z() - r.bounds_min.z() << " m (x y z)\n"
            << "area       " << r.area << " m² (both layers)\n"
            << "edges      min " << r.edge_min << "  mean " << r.edge_mean << "  max " << r.edge_max << " m\n"
            << "min angle  " << std::setprecision(1) << r.min_angle_deg << " deg\n"
            << "topology   " << r.components << " component(s), " << r.boundary_loops << " boundary loop(s), "
            << (r.Manifold() ? "manifold" : "NON-MANIFOLD") << ", "
            << (r.Oriented() ? "consistently oriented" : std::to_string(r.inconsistent_edges) + " flipped edges")
            << "\n";
  std::cout << "anchors    " << g.anchors.size() << "\n" << std::setprecision(4);
  for (const Anchor& a : g.anchors) {
    std::cout << "  " << std::left << std::setw(18) << a.label << " vertex " << std::right << std::setw(5) << a.vertex
              << "  (" << a.position.x() << ", " << a.position.y() << ", " << a.position.z() << ")\n";
  }
}

int Make(const GarmentsArgs& args) {
  TemplateOptions opt = args.make;
  opt.size = args.size;
  for (const std::string& kv : args.param) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) throw Error("--param: expected NAME=VALUE, got '" + kv + "'");
    const std::string value = kv.substr(eq + 1);
    char* end = nullptr;
    const double d = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0') throw Error("--param " + kv + ": '" + value + "' is not a number");
    opt.params[kv.substr(0, eq)] = d;
  }
  ValidateOptions(
      opt,
      {{&opt.edge_length, "--edge-length"}, {&opt.layer_gap, "--layer-gap"}, {&opt.perturbation, "--perturbation"}});
  const std::string& out = args.output;
  MeshStats stats;
  const Garment g = MakeGarment(args.name, opt, &stats);
  ExportGarment(g, out);
  std::cout << "wrote " << out << " and " << AnchorsPath(out).string() << "\n";
  if (!args.preview.empty()) {
    WriteFileAtomic(args.preview, RenderFlatPreview(g));
    std::cout << "wrote " << args.preview << "\n";
  }
  PrintGarment(g, InspectMesh(g.mesh));
  std::cout << std::setprecision(2) << "edge/target p05 " << stats.ratio_p05 << "  p95 " << stats.ratio_p95 << "  (min "
            << stats.ratio_min << ", max " << stats.ratio_max << ")\n";
  return 0;
}

int Show(const GarmentsArgs& args) {
  const fs::path mesh = args.name;
  fs::path anchors = args.anchors;
  if (anchors.empty() && fs::exists(AnchorsPath(mesh))) anchors = AnchorsPath(mesh);
  const ImportOptions& opt = args.show;
  ValidateOptions(opt, {{&opt.unit_scale, "--unit-scale"}, {&opt.max_anchor_distance, "--max-anchor-distance"}});
  ImportReport report;
  const Garment g = ImportGarment(mesh, anchors, opt, &report);
  std::cout << "file       " << mesh.string() << "\n"
            << "anchors    " << (anchors.empty() ? std::string("(none)") : anchors.string()) << "\n";
  for (const auto& w : report.warnings) std::cout << "warning: " << w << "\n";
  PrintGarment(g, InspectMesh(g.mesh));
  if (!args.preview.empty()) {
    WriteFileAtomic(args.preview, RenderFlatPreview(g));
    std::cout << "wrote " << args.preview << "\n";
  }
  return 0;
}

Runner Setup(CLI::App& app) {
  auto a = std::make_shared<GarmentsArgs>();
  app.require_subcommand(1);
  CLI::App* list = app.add_subcommand("list", "list the templates with category, anchor count and openings");
  list->add_flag("--params", a->params, "also each template's size parameters with their S/M/L presets");

  CLI::App* make = app.add_subcommand("make", "build a flat two-layer garment from a template");
  make->footer(
      "Writes the mesh plus OUT.anchors.json beside it (format from the extension: ply, obj, glb, gltf, stl).");
  make->add_option("TEMPLATE", a->name, "a template (drape garments list)")->required();
  AddOutput(*make, a->output, "mesh file to write")->required();
  make->add_option("--size", a->size, "size preset")->check(CLI::IsMember({"S", "M", "L"}))->capture_default_str();
  AddSeed(*make, a->make.seed,
          "0 = the preset's proportions; other values perturb every parameter by up to ±perturbation");
  make->add_option("--edge-length", a->make.edge_length, "target mesh edge length (m)")->capture_default_str();
  make->add_option("--layer-gap", a->make.layer_gap, "distance between front and back layer (m)")
      ->capture_default_str();
  make->add_option("--perturbation", a->make.perturbation, "relative perturbation for --seed")->capture_default_str();
  make->add_option("--param", a->param, "set a size parameter exactly (m; radians for angles); repeatable")
      ->type_name("NAME=VALUE");
  make->add_option("--preview", a->preview, "also write a preview picture")->type_name("PNG");

  CLI::App* show = app.add_subcommand("show", "import a mesh with its anchors, validate it and describe it");
  show->add_option("FILE", a->name, "a mesh file (any format assimp reads)")->required();
  show->add_option("--anchors", a->anchors, "anchors sidecar (default: FILE's NAME.anchors.json if present)")
      ->type_name("PATH");
  show->add_option("--unit-scale", a->show.unit_scale, "multiply file coordinates by S (e.g. 0.01 for cm)")
      ->type_name("S")
      ->capture_default_str();
  show->add_option("--max-anchor-distance", a->show.max_anchor_distance,
                   "how far an anchor position may be from the surface (m)")
      ->capture_default_str();
  show->add_option("--preview", a->preview, "write a preview picture")->type_name("PNG");
  return [a, list, make] {
    if (list->parsed()) return List(*a);
    if (make->parsed()) return Make(*a);
    return Show(*a);
  };
}

Register reg({"garments", "garment templates, imports and previews (list, make, show)", Setup});

}  // namespace
}  // namespace drape::cli
