#include "generator/hang/material.h"

#include <cmath>
#include <numbers>

#include "common/error.h"
#include "common/field_error.h"
#include "common/format.h"

namespace drape {

double Material::FrictionCoefficient() const { return std::tan(friction_deg * std::numbers::pi / 180.0); }

double Material::BendingLength() const { return std::cbrt(bending_rigidity / (area_density * 9.81)); }

void Material::Validate() const {
  auto bad = [&](const auto& field, const char* field_name, const std::string& what) {
    BadField(field, "material '" + name + "': " + field_name, what);
  };
  if (!(stretch_percent > 0 && stretch_percent <= 30))
    bad(stretch_percent, "stretch_percent", "must be in (0, 30], got " + FormatNumber(stretch_percent));
  if (!(friction_deg >= 0 && friction_deg < 90))
    bad(friction_deg, "friction_deg", "must be in [0, 90), got " + FormatNumber(friction_deg));
  if (!(area_density > 0.01 && area_density <= 5))
    bad(area_density, "area_density", "must be in (0.01, 5] kg/m², got " + FormatNumber(area_density));
  if (!(bending_stiffness > 0 && bending_stiffness <= 1))
    bad(bending_stiffness, "bending_stiffness", "must be in (0, 1], got " + FormatNumber(bending_stiffness));
  if (!(bending_rigidity >= 0 && bending_rigidity <= 0.01))
    bad(bending_rigidity, "bending_rigidity", "must be in [0, 0.01] N·m, got " + FormatNumber(bending_rigidity));
  if (!(crease_yield >= 0 && crease_yield <= 1e5))
    bad(crease_yield, "crease_yield", "must be in [0, 1e5] 1/m (0: no creases), got " + FormatNumber(crease_yield));
  if (!(crease_weakening >= 0 && crease_weakening <= 100))
    bad(crease_weakening, "crease_weakening", "must be in [0, 100], got " + FormatNumber(crease_weakening));
  if (!(crease_recovery_deg >= 0 && crease_recovery_deg < 180))
    bad(crease_recovery_deg, "crease_recovery",
        "must be in [0, 180) degrees (0: none measured), got " + FormatNumber(crease_recovery_deg));
  if (crease_recovery_deg > 0 && crease_yield > 0)
    bad(crease_recovery_deg, "crease_recovery",
        "is fitted into the yield: give crease_recovery or crease_yield, not both");
  if (crease_recovery_deg > 0 && !(bending_rigidity > 0))
    bad(crease_recovery_deg, "crease_recovery", "needs hinge bending (bending_rigidity > 0)");
}

const std::vector<Material>& MaterialPresets() {
  // name, stretch %, friction ° (the paper's table), kg/m² per layer, relative bending
  // links (unused: B > 0), B in N·m (hinge bending), crease yield 1/m, weakening.
  // B and weight: Wang, O'Brien & Ramamoorthi 2011 (ARCSim materials/*.json, the 0°,
  // lowest-curvature entry, read as B itself: recipes/README.md "Presets" says why and
  // cites every number). Only `shirting` creases: its recovery angle is measured
  // (crease_recovery_deg, the last field; the yield is fitted to it).
  static const std::vector<Material> presets = {
      {"tshirt", 2.9, 24.3, 0.187, 0.0075, 23.2e-6},  // gray interlock (jersey), c 2.33 cm
      {"jeans", 2.9, 19.1, 0.324, 0.05, 64.2e-6},     // 11 oz black denim, c 2.72 cm
      {"pants", 1.7, 21.9, 0.220, 0.025, 125.4e-6},   // royal target (pants, 65/35 cotton/poly), c 3.87 cm
      {"towel_a", 2.2, 18.7, 0.40, 0.02, 27.5e-6},    // large towel, terry (B: Feng et al. 2022's
      {"towel_b", 3.1, 22.3, 0.35, 0.02, 27.5e-6},    //   median bending length 2.0 cm at 0.35 kg/m²;
      {"towel_c", 1.1, 24.3, 0.30, 0.02, 27.5e-6},    //   no terry measurement at hand)
      // Untreated woven cotton shirting: bending lengths 2.3 / 1.52 cm (warp / weft, overall
      // √(2.3·1.52) = 1.87 cm) and total crease recovery 155° (warp + weft: 77.5° each way)
      // of Dhiman & Chakraborty 2017's unfinished cotton; 125 g/m² poplin shirting; B = W·g·c³.
      // Stretch and table friction: the paper's long-sleeve shirt.
      {"shirting", 2.9, 24.3, 0.125, 0.02, 8.02e-6, 0, 0, 77.5},
  };
  return presets;
}

const Material* FindMaterialPreset(std::string_view name) {
  for (const Material& m : MaterialPresets())
    if (m.name == name) return &m;
  return nullptr;
}

}  // namespace drape
