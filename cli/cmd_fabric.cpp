// drape fabric TEST: the textile lab's standard tests on the cloth core (generator/hang's
// cantilever.h and lab.h), each printing the figure a lab reports beside what the
// material's own values say it should be (docs/fabric.md).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <numbers>
#include <string>

#include "cli/command.h"
#include "cli/options.h"
#include "common/error.h"
#include "common/json.h"
#include "generator/hang/cantilever.h"
#include "generator/hang/lab.h"
#include "generator/hang/material.h"
#include "generator/recipe/recipe.h"

namespace drape::cli {
namespace {

const char* kFooter =
    "The material is a preset (tshirt, jeans, pants, towel_a, ...) or, with --recipe, one of\n"
    "the recipe's materials (recipes/README.md: bending_rigidity, crease_yield, ...). Its\n"
    "simulation constants are fitted as a build fits them at the mesh edge --edge\n"
    "(generator/hang FitMaterial: link stiffness to the stretch, the hinge constant to the\n"
    "cantilever's bending length (B/W)^(1/3), the table friction to the friction angle);\n"
    "--hinge-constant C uses C instead of the fitted one (1: the continuum's hinge, whose\n"
    "cantilever reads short on coarse rows, docs/fabric.md). The incline's cloth-on-cloth\n"
    "friction is tan(friction angle) of the material.";

struct FabricArgs {
  std::string material = "tshirt", recipe;
  double edge = 0.02;
  double hinge_constant = 0;  // 0: the fitted one
  double angle = 20;          // incline
  int seeds = 5;              // drape
  bool json = false;
};

Material FindMaterial(const FabricArgs& a) {
  if (!a.recipe.empty()) {
    const Recipe r = LoadRecipe(a.recipe);
    const auto it = r.materials.find(a.material);
    if (it != r.materials.end()) return it->second;
  }
  const Material* m = FindMaterialPreset(a.material);
  if (!m) throw Error("--material: no material '" + a.material + "'" + (a.recipe.empty() ? "" : " in " + a.recipe));
  return *m;
}

// The material, its constants fitted at the test's edge length, and the solver options.
LabCloth Cloth(const FabricArgs& a) {
  LabCloth c;
  c.material = FindMaterial(a);
  c.hang.fit_edge_length = a.edge;
  c.hang.fit_hinge_constant = a.hinge_constant;  // > 0: kLST fitted alone with this C
  c.fit = FitMaterial(c.material, c.hang);
  c.fit.cloth_friction = c.material.FrictionCoefficient();
  return c;
}

void Print(const FabricArgs& a, const Json& j, const std::string& text) {
  if (a.json)
    std::cout << j.dump(2) << "\n";
  else
    std::cout << text;
}

std::string Fmt(const char* format, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

int Cantilever(const FabricArgs& a) {
  const LabCloth c = Cloth(a);
  if (!(c.material.bending_rigidity > 0))
    throw Error("--material: '" + c.material.name +
                "' has no bending_rigidity (the cantilever reads B; give one in a recipe's materials, --recipe)");
  CantileverOptions o;
  o.edge_length = a.edge;
  const CantileverResult r = RunCantilever(c.material, c.fit, c.hang, o);
  if (!r.failure.empty()) throw NumericalError("cantilever: " + r.failure);
  const double w = c.material.area_density * 9.81, c0 = c.material.BendingLength();
  const Json j = {{"bending_length", r.bending_length},
                  {"bending_rigidity", c.material.bending_rigidity},
                  {"weight", w},
                  {"edge", a.edge}};
  Print(a, j,
        "cantilever (ASTM D1388 option A), " + c.material.name + ", edge " + Fmt("%.3g", a.edge) + " m, " +
            std::to_string(r.nodes) + " nodes, hinge constant " + Fmt("%.3g", c.fit.bending_scale) +
            "\n  bending length c  " + Fmt("%.4f", r.bending_length) + " m (overhang " + Fmt("%.4f", r.overhang) +
            " m, chord " + Fmt("%.1f", r.chord_angle * 180 / std::numbers::pi) + " deg)\n  expected (B/W)^(1/3) " +
            Fmt("%.4f", c0) + " m  from the material's B " + Fmt("%.3g", c.material.bending_rigidity) + " N m and W " +
            Fmt("%.3g", w) + " N/m^2  (ratio " + Fmt("%.3f", r.bending_length / c0) + ")\n" +
            (c.fit.converged ? ""
                             : "  the constants' fit did not converge: " +
                                   (c.fit.note.empty() ? "outside its tolerances" : c.fit.note) + "\n"));
  return 0;
}

int Drape(const FabricArgs& a) {
  const LabCloth c = Cloth(a);
  DrapeOptions o;
  o.edge_length = a.edge;
  o.seeds.clear();
  for (int s = 1; s <= a.seeds; ++s) o.seeds.push_back(static_cast<uint64_t>(s));
  const DrapeResult r = RunDrape(c, o);
  Json folds = Json::array();
  std::string per_seed;
  for (const DrapeRun& run : r.runs) {
    folds.push_back(run.folds);
    per_seed += "  seed " + std::to_string(run.seed) + ": coefficient " + Fmt("%.3f", run.coefficient) + ", " +
                std::to_string(run.folds) + " folds" + (run.failure.empty() ? "" : ", failed: " + run.failure) +
                (run.settled ? ", settled" : ", not settled") + " after " + Fmt("%.2f", run.sim_time) +
                " s (last window's largest move " + Fmt("%.2g", 1e3 * run.motion) + " mm)\n";
  }
  Print(a, {{"drape_coefficient", r.drape_coefficient}, {"folds", folds}},
        "Cusick drape (BS 5058, 30 cm on an 18 cm disc), " + c.material.name + ", edge " + Fmt("%.3g", a.edge) +
            " m, " + std::to_string(r.nodes) + " nodes\n  drape coefficient " + Fmt("%.3f", r.drape_coefficient) +
            " (median over " + std::to_string(o.seeds.size()) +
            " seeds)\n  expected: no measured drape recorded for the material (docs/fabric.md)\n" + per_seed);
  return 0;
}

int Incline(const FabricArgs& a) {
  const LabCloth c = Cloth(a);
  InclineOptions o;
  o.edge_length = a.edge;
  o.angle_deg = a.angle;
  const InclineResult r = RunIncline(c, o);
  if (!r.failure.empty()) throw NumericalError("incline: " + r.failure);
  const double angle = std::atan(r.friction) * 180 / std::numbers::pi;
  const std::string moved = r.slid_off ? "slid off the " + Fmt("%.3g", o.base * 100) + " cm base after " +
                                             Fmt("%.2f", r.off_time) + " s (its centre past the base's edge, " +
                                             Fmt("%.4f", r.slide) + " m)"
                                       : "slide " + Fmt("%.4f", r.slide) + " m in " + Fmt("%.3g", o.time) + " s";
  Print(a,
        {{"slide", r.slide},
         {"friction", r.friction},
         {"slid_off", r.slid_off},
         {"off_time", r.slid_off ? Json(r.off_time) : Json(nullptr)}},
        "incline, " + c.material.name + " on itself at " + Fmt("%.3g", a.angle) + " deg, edge " + Fmt("%.3g", a.edge) +
            " m\n  " + moved + "\n  expected: " + (a.angle < angle ? "stays" : "slides") + " (cloth-on-cloth mu " +
            Fmt("%.3f", r.friction) + ", friction angle " + Fmt("%.1f", angle) +
            " deg, the material's friction_deg)\n");
  return 0;
}

int Crease(const FabricArgs& a) {
  const LabCloth c = Cloth(a);
  const CreaseOptions o = CreaseOptionsAt(a.edge);
  const CreaseResult r = RunCrease(c, o);
  if (!r.failure.empty()) throw NumericalError("crease: " + r.failure);
  const Material& m = c.material;
  const double yield = m.crease_recovery_deg > 0 ? c.fit.crease_yield : m.crease_yield;
  const std::string expected =
      m.crease_recovery_deg > 0
          ? Fmt("%.1f", m.crease_recovery_deg) + " deg, the material's measured recovery angle (AATCC 66; the yield " +
                "is fitted to it at this edge)"
          : (yield > 0 ? std::string("no measured recovery angle recorded for the material")
                       : std::string("180 deg: the material does not crease (crease_yield 0)"));
  Print(a, {{"open_angle", r.open_angle}},
        "crease recovery (" + Fmt("%.3g", o.length * 100) + " x " + Fmt("%.3g", o.width * 100) +
            " cm, folded 180 deg, pressed " + Fmt("%.3g", o.press_time) + " s), " + m.name + ", edge " +
            Fmt("%.3g", a.edge) + " m\n  open angle " + Fmt("%.1f", r.open_angle) + " deg after " +
            Fmt("%.3g", o.recovery_time) + " s (the press left a rest angle of " + Fmt("%.1f", r.rest_angle) +
            " deg; crease_yield " + Fmt("%.3g", yield) + " 1/m)\n  expected: " + expected + "\n");
  return 0;
}

void AddCommon(CLI::App& t, FabricArgs& a) {
  t.add_option("--material", a.material, "a preset, or with --recipe one of the recipe's materials")
      ->type_name("NAME")
      ->capture_default_str();
  t.add_option("--recipe", a.recipe, "a recipe whose materials --material may name")->type_name("PATH");
  t.add_option("--edge", a.edge, "mesh edge length (m)")->check(NumberIn(0.003, 0.1))->capture_default_str();
  t.add_option("--hinge-constant", a.hinge_constant, "use this hinge constant C instead of the fitted one")
      ->type_name("C")
      ->check(NumberIn(0.01, 100));
  AddJson(t, a.json);
}

Runner Setup(CLI::App& app) {
  auto a = std::make_shared<FabricArgs>();
  app.require_subcommand(1);
  app.footer(kFooter);
  CLI::App* cantilever =
      app.add_subcommand("cantilever", "ASTM D1388 option A: a 2.5 x 20 cm strip over a 41.5 deg edge; c = overhang/2");
  CLI::App* drape = app.add_subcommand("drape", "the Cusick drape test (BS 5058), over seeds");
  CLI::App* incline = app.add_subcommand("incline", "a 20 x 20 cm sheet on a sheet of the same fabric on a slope");
  CLI::App* crease = app.add_subcommand("crease", "a 20 x 10 cm strip folded 180 deg, pressed 2 s, released");
  for (CLI::App* t : {cantilever, drape, incline, crease}) AddCommon(*t, *a);
  AddCount(*drape, "--seeds", a->seeds, "drapes run (seeds 1..N)", 1, 100);
  incline->add_option("--angle", a->angle, "tilt of the plane (degrees)")
      ->check(NumberIn(0, 89))
      ->capture_default_str();
  return [a, cantilever, drape, incline] {
    if (cantilever->parsed()) return Cantilever(*a);
    if (drape->parsed()) return Drape(*a);
    if (incline->parsed()) return Incline(*a);
    return Crease(*a);
  };
}

Register reg({"fabric", "the textile lab's tests on the cloth core (cantilever, drape, incline, crease)", Setup});

}  // namespace
}  // namespace drape::cli
