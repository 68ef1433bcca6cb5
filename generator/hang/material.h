// Garment materials as a person measures them (paper §"Parameter Adaptation"):
// stretch % when hung from an extremum vs laid flat, and the friction angle on a
// table; plus what the simulation also needs (mass per area, bending stiffness).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace drape {

struct Material {
  std::string name;
  // shear_frac × 100, shear_frac = (L1 − L2)/L2: L1 = pick point → lowest point when hung
  // from an extremum, L2 = the same two points' distance laid flat. Paper's table: 1.1–3.1.
  double stretch_percent = 2.4;
  // Angle of a tilted table at which the garment starts to slide, degrees (μ = tan).
  double friction_deg = 22.2;
  // Mass per area of ONE layer of fabric, kg/m² (cotton jersey ~0.15, denim ~0.35).
  double area_density = 0.2;
  // Bending stiffness RELATIVE to stretch stiffness, dimensionless in (0, 1]: the
  // stiffness of the bending springs (links across each interior edge, between the two
  // opposite vertices) as a fraction of the structural links' stiffness (Bullet link
  // kLST). Fabric's own bending rigidity (~1e-5–1e-4 N·m, a Peirce bending length of
  // 1–4 cm) is below what a 2.5–5 cm mesh resolves, so these are set low, not measured:
  // at 0.08 a towel hung from a corner carried its weight × 7.8 cm at the grip (its
  // centre of mass that far sideways); at 0.02 it hangs within the held patch + 2 cm.
  // Softer still (0.004) lays a towel carried by two corners on the table in a heap
  // (coverage 0.29 instead of > 0.7). Unused by the presets: they bend on hinges
  // (bending_rigidity below; recipes/README.md, "Presets").
  double bending_stiffness = 0.02;
  // Bending rigidity B of one layer, N·m: moment per unit width per unit curvature (KES-FB
  // reports gf·cm²/cm; 1 gf·cm²/cm = 98 µN·m). > 0: hinge bending
  // (generator/cloth/bending.h) with this B replaces the relative bending links above.
  double bending_rigidity = 0;
  // Creases (Narain et al. 2013): the curvature (1/m) beyond which a fold's rest angle
  // yields (0: never), and how much a yielded fold weakens (stiffness ÷ (1 + weakening ×
  // damage)).
  double crease_yield = 0;
  double crease_weakening = 0;
  // The crease recovery angle a lab measured (AATCC 66 / ISO 2313: folded 180°, pressed,
  // released; the angle the fold opens to), degrees; 0: none measured. > 0: FitMaterial
  // fits the yield curvature at the mesh's edge length so that the lab's crease test
  // (lab.h) opens to this angle, and crease_yield must be 0.
  double crease_recovery_deg = 0;

  // Friction coefficient μ = tan(friction_deg).
  double FrictionCoefficient() const;
  // Bending length c = (B / (ρ g))^(1/3), m: what a cantilever test measures (0 without B).
  double BendingLength() const;
  // Throws drape::Error naming the bad field.
  void Validate() const;
};

// The paper's measured table (Fig. "garment_stat_fold"), names "tshirt", "jeans",
// "pants", "towel_a" (large), "towel_b" (medium), "towel_c" (small). Stretch and
// friction are the paper's; weight and bending rigidity are measured (recipes/README.md).
const std::vector<Material>& MaterialPresets();
// nullptr if unknown.
const Material* FindMaterialPreset(std::string_view name);

}  // namespace drape
