// drape register SOURCE TARGET: scale + rigid ICP + non-rigid registration of a mesh
// onto another (paper §"Deformable Registration"), with anchor transfer.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/command.h"
#include "cli/config.h"
#include "cli/options.h"
#include "cli/sections.h"
#include "common/error.h"
#include "garments/io.h"
#include "runtime/registration/registration.h"

namespace fs = std::filesystem;

namespace drape::cli {
namespace {

const char* kFooter =
    "Registers SOURCE (e.g. a database entry's hang.ply) onto TARGET (e.g. a recon.ply):\n"
    "scales SOURCE to TARGET's size, aligns it by ICP on a closest-point grid, then deforms\n"
    "it by minimising E_fit + kappa E_area + beta E_angle + alpha E_hinge (secant\n"
    "Levenberg-Marquardt). Prints the paper's registration errors (area-weighted mean\n"
    "distance, one sample per triangle, metres) source->target and target->source, for\n"
    "rigid only (R) and rigid + non-rigid (R+N), and the transferred anchors. The energy\n"
    "weights, grid and solver settings are the options file's `registration` section.";

using registration::RegistrationOptions;

struct RegisterArgs {
  std::string source, target, output, anchors, config;
  bool rigid_only = false, json = false;
};

// SOURCE with its anchors: the explicit sidecar, else SOURCE's own if there is one.
Garment LoadSource(const RegisterArgs& args, const fs::path& source_path) {
  fs::path anchors_path = args.anchors;
  if (anchors_path.empty() && fs::exists(AnchorsPath(source_path))) anchors_path = AnchorsPath(source_path);
  Garment garment;
  if (!anchors_path.empty()) {
    garment = ImportGarment(source_path, anchors_path, ImportOptions{});
  } else {
    garment.mesh = ReadMesh(source_path);
  }
  return garment;
}

void PrintRegistration(const registration::RegistrationEvaluation& ev, const RegistrationOptions& opt,
                       const fs::path& source_path, const TriMesh& source, const fs::path& target_path,
                       const TriMesh& target, const std::string& out) {
  const registration::RegistrationReport& r = ev.report;
  std::printf("source %s: %d vertices, %d faces; target %s: %d vertices, %d faces\n", source_path.c_str(),
              source.NumVertices(), source.NumFaces(), target_path.c_str(), target.NumVertices(), target.NumFaces());
  std::printf("scale %.4f; grid %dx%dx%d (h = %.4f m); ICP %d iterations (%s), RMS %.4f -> %.4f m\n", r.scaling.scale,
              r.grid.nx, r.grid.ny, r.grid.nz, r.grid.spacing, r.icp.iterations,
              r.icp.converged ? "converged" : "not converged", r.icp.rms_before, r.icp.rms_after);
  if (opt.nonrigid)
    std::printf(
        "non-rigid: %d LM iterations (%d accepted, %d fresh Jacobians, %d secant updates, stop: %s)\n"
        "  E_fit %.3e -> %.3e; kappa E_area %.3e, beta E_angle %.3e, alpha E_hinge %.3e\n",
        r.lm.iterations, r.lm.accepted, r.lm.fresh_jacobians, r.lm.secant_updates, r.lm.termination.c_str(),
        r.energy_before.fit, r.energy_after.fit, r.energy_after.area, r.energy_after.angle, r.energy_after.hinge);
  std::printf("error (m)      S->T      T->S\n");
  std::printf("  R        %8.5f  %8.5f\n", ev.s_to_t_rigid.mean, ev.t_to_s_rigid.mean);
  if (opt.nonrigid) std::printf("  R+N      %8.5f  %8.5f\n", ev.s_to_t_nonrigid.mean, ev.t_to_s_nonrigid.mean);
  for (const auto& a : ev.anchors) {
    const Vec3 p = opt.nonrigid ? a.nonrigid : a.rigid;
    std::printf("anchor %-16s vertex %6d -> (%.4f, %.4f, %.4f)\n", a.label.c_str(), a.source_vertex, p.x(), p.y(),
                p.z());
  }
  for (const auto& w : r.warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("time %.2f s (grid %.2f, ICP %.2f, non-rigid %.2f)%s%s\n", ev.seconds, r.grid_seconds, r.icp_seconds,
              r.nonrigid_seconds, out.empty() ? "" : "; wrote ", out.c_str());
}

int Run(const RegisterArgs& args) {
  const fs::path source_path = args.source, target_path = args.target;
  RegistrationOptions opt;
  kRegistrationSection.Read(OptionsFile::LoadIfGiven(args.config), opt);
  opt.nonrigid = !args.rigid_only;
  opt.Validate();
  const Garment garment = LoadSource(args, source_path);
  const TriMesh target = ReadMesh(target_path);

  std::vector<registration::AnchorPair> pairs;
  for (const Anchor& a : garment.anchors) pairs.push_back({a.label, a.vertex, false, Vec3::Zero()});
  registration::RegistrationResult result;
  const registration::RegistrationEvaluation ev =
      registration::RegisterAndEvaluate(garment.mesh, target, pairs, opt, &result);
  const TriMesh& out_mesh = opt.nonrigid ? result.nonrigid : result.rigid;

  const std::string& out = args.output;
  if (!out.empty()) {
    if (!garment.anchors.empty()) {
      Garment moved = garment;
      moved.mesh = out_mesh;
      for (Anchor& a : moved.anchors) a.position = out_mesh.V.row(a.vertex);
      ExportGarment(moved, out);
    } else {
      WriteMesh(out_mesh, out);
    }
  }

  if (args.json) {
    Json j = registration::ToJson(ev);
    j["source"] = source_path.string();
    j["target"] = target_path.string();
    if (!out.empty()) j["output"] = out;
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  PrintRegistration(ev, opt, source_path, garment.mesh, target_path, target, out);
  return 0;
}

Runner Setup(CLI::App& app) {
  auto a = std::make_shared<RegisterArgs>();
  app.footer(kFooter);
  app.add_option("SOURCE", a->source, "the mesh to move (with its NAME.anchors.json if present)")->required();
  app.add_option("TARGET", a->target, "the mesh to register onto")->required();
  AddOutput(app, a->output,
            "write the registered source (R+N, or R with --rigid-only); with anchors, also its NAME.anchors.json "
            "with the moved anchors");
  app.add_flag("--rigid-only", a->rigid_only, "skip the non-rigid step");
  app.add_option("--anchors", a->anchors, "SOURCE's anchors sidecar (default: SOURCE's NAME.anchors.json if present)")
      ->type_name("PATH");
  AddJson(app, a->json);
  AddConfig(app, a->config);
  return [a] { return Run(*a); };
}

Register reg({"register", "register a mesh onto another (scale, ICP, non-rigid), transfer anchors", Setup});

}  // namespace
}  // namespace drape::cli
