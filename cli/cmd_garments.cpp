// drape garments list|make|show: the garment library from the command line.
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli/args.h"
#include "cli/command.h"
#include "common/error.h"
#include "common/files.h"
#include "garments/io.h"
#include "garments/preview.h"
#include "garments/templates.h"
#include "garments/validate.h"

namespace fs = std::filesystem;

namespace drape::cli {
namespace {

const char* kUsage =
    "Usage: drape garments list\n"
    "       drape garments make TEMPLATE [options] -o OUT.ply|obj|glb|gltf|stl\n"
    "       drape garments show FILE [--anchors FILE.anchors.json] [--preview OUT.png]\n"
    "\n"
    "Garment templates (procedural, with labelled anchors), imports and previews.\n"
    "See `drape garments SUBCOMMAND --help`.\n";

const char* kListUsage =
    "Usage: drape garments list [--params]\n"
    "\n"
    "Lists the garment templates with category, anchor count and openings.\n"
    "  --params   also list each template's size parameters with their S/M/L presets\n";

const char* kMakeUsage =
    "Usage: drape garments make TEMPLATE [--size S|M|L] [--seed N] [--edge-length M]\n"
    "                            [--layer-gap M] [--perturbation P] [--param NAME=VALUE ...]\n"
    "                            -o OUT.ply|obj|glb|gltf|stl [--preview OUT.png]\n"
    "\n"
    "Builds a flat two-layer garment from a template and writes the mesh plus\n"
    "OUT.anchors.json beside it.\n"
    "  --size S|M|L        size preset (default M)\n"
    "  --seed N            0 = preset proportions (default); other values perturb every\n"
    "                      parameter by up to ±perturbation, deterministically\n"
    "  --edge-length M     target mesh edge length in metres (default 0.025)\n"
    "  --layer-gap M       distance between front and back layer (default 0.01)\n"
    "  --perturbation P    relative perturbation for --seed (default 0.05)\n"
    "  --param NAME=VALUE  set a size parameter exactly (metres; radians for angles);\n"
    "                      repeatable; see `drape garments list --params`\n"
    "  -o, --output PATH   mesh file to write (format from the extension)\n"
    "  --preview PNG       also write a preview picture\n";

const char* kShowUsage =
    "Usage: drape garments show FILE [--anchors FILE.anchors.json] [--preview OUT.png]\n"
    "                            [--unit-scale S] [--max-anchor-distance M]\n"
    "\n"
    "Imports a mesh (any format assimp reads) with its anchors, validates it and prints\n"
    "vertex/face counts, size, area, mesh quality and anchors.\n"
    "  --anchors PATH            anchors sidecar (default: FILE's NAME.anchors.json if present)\n"
    "  --unit-scale S            multiply file coordinates by S (e.g. 0.01 for cm)\n"
    "  --max-anchor-distance M   how far an anchor position may be from the surface (0.02)\n"
    "  --preview PNG             write a preview picture\n";

int List(const std::vector<std::string>& argv) {
  Args args(argv, {"--params"}, {});
  if (args.help()) {
    std::cout << kListUsage;
    return 0;
  }
  args.RequirePositional(0, 0, "no positional arguments");
  std::cout << std::left << std::setw(20) << "template" << std::setw(20) << "category" << std::setw(9) << "anchors"
            << "openings\n";
  for (const auto& t : Templates()) {
    std::string openings;
    for (const auto& o : t.openings) openings += (openings.empty() ? "" : ", ") + o;
    std::cout << std::left << std::setw(20) << t.name << std::setw(20) << t.category << std::setw(9)
              << t.anchor_labels.size() << (openings.empty() ? "(none)" : openings) << "\n";
    if (args.Flag("--params")) {
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

int Make(const std::vector<std::string>& argv) {
  Args args(
      argv, {},
      {"--size", "--seed", "--edge-length", "--layer-gap", "--perturbation", "--param", "-o", "--output", "--preview"});
  if (args.help()) {
    std::cout << kMakeUsage;
    return 0;
  }
  args.RequirePositional(1, 1, "one TEMPLATE (see drape garments list)");
  TemplateOptions opt;
  opt.size = args.Get("--size", opt.size);
  if (auto s = args.GetSeed("--seed")) opt.seed = *s;
  if (auto v = args.GetDouble("--edge-length")) opt.edge_length = *v;
  if (auto v = args.GetDouble("--layer-gap")) opt.layer_gap = *v;
  if (auto v = args.GetDouble("--perturbation")) opt.perturbation = *v;
  for (const std::string& kv : args.GetAll("--param")) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) throw Error("option --param: expected NAME=VALUE, got '" + kv + "'");
    const std::string value = kv.substr(eq + 1);
    char* end = nullptr;
    const double d = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0') throw Error("option --param " + kv + ": '" + value + "' is not a number");
    opt.params[kv.substr(0, eq)] = d;
  }
  auto out = args.Get("-o");
  if (!out) out = args.Get("--output");
  if (!out) throw Error("missing -o OUT.ply|obj|glb (see --help)");
  MeshStats stats;
  const Garment g = MakeGarment(args.positional()[0], opt, &stats);
  ExportGarment(g, *out);
  std::cout << "wrote " << *out << " and " << AnchorsPath(*out).string() << "\n";
  if (auto png = args.Get("--preview")) {
    WriteFileAtomic(*png, RenderFlatPreview(g));
    std::cout << "wrote " << *png << "\n";
  }
  PrintGarment(g, InspectMesh(g.mesh));
  std::cout << std::setprecision(2) << "edge/target p05 " << stats.ratio_p05 << "  p95 " << stats.ratio_p95 << "  (min "
            << stats.ratio_min << ", max " << stats.ratio_max << ")\n";
  return 0;
}

int Show(const std::vector<std::string>& argv) {
  Args args(argv, {}, {"--anchors", "--preview", "--unit-scale", "--max-anchor-distance"});
  if (args.help()) {
    std::cout << kShowUsage;
    return 0;
  }
  args.RequirePositional(1, 1, "one mesh FILE");
  const fs::path mesh = args.positional()[0];
  fs::path anchors;
  if (auto a = args.Get("--anchors")) {
    anchors = *a;
  } else if (fs::exists(AnchorsPath(mesh))) {
    anchors = AnchorsPath(mesh);
  }
  ImportOptions opt;
  if (auto v = args.GetDouble("--unit-scale")) opt.unit_scale = *v;
  if (auto v = args.GetDouble("--max-anchor-distance")) opt.max_anchor_distance = *v;
  ImportReport report;
  const Garment g = ImportGarment(mesh, anchors, opt, &report);
  std::cout << "file       " << mesh.string() << "\n"
            << "anchors    " << (anchors.empty() ? std::string("(none)") : anchors.string()) << "\n";
  for (const auto& w : report.warnings) std::cout << "warning: " << w << "\n";
  PrintGarment(g, InspectMesh(g.mesh));
  if (auto png = args.Get("--preview")) {
    WriteFileAtomic(*png, RenderFlatPreview(g));
    std::cout << "wrote " << *png << "\n";
  }
  return 0;
}

int Run(const std::vector<std::string>& argv) {
  if (argv.empty() || argv[0] == "--help" || argv[0] == "-h" || argv[0] == "help") {
    std::cout << kUsage;
    return argv.empty() ? 2 : 0;
  }
  const std::string sub = argv[0];
  const std::vector<std::string> rest(argv.begin() + 1, argv.end());
  if (sub == "list") return List(rest);
  if (sub == "make") return Make(rest);
  if (sub == "show") return Show(rest);
  throw Error("unknown subcommand '" + sub + "' (expected list, make or show)");
}

Register reg({"garments", "garment templates, imports and previews (list, make, show)", kUsage, Run});

}  // namespace
}  // namespace drape::cli
