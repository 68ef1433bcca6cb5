// Procedural garment templates: parametric 2D outlines of garments laid flat (front
// up, y up, wearer facing +z so the wearer's left is +x), with their openings and
// labelled anchors, meshed through GarmentFromContour (contour.h).
//
// Templates: long_sleeve_shirt, tshirt, pants, shorts, skirt, towel. Anchor labels
// are documented in garments/anchors.md.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "garments/contour.h"
#include "garments/garment.h"

namespace drape {

// One named size parameter (metres, or radians for angles) with its S/M/L presets.
struct TemplateParameter {
  std::string name;
  std::string description;
  double small = 0, medium = 0, large = 0;
  bool angle = false;  // radians instead of metres
};

struct TemplateInfo {
  std::string name;      // "long_sleeve_shirt", ...
  std::string category;  // Garment::category of what MakeGarment builds (== name)
  std::string description;
  std::vector<std::string> anchor_labels;  // in the order of Garment::anchors
  std::vector<TemplateParameter> parameters;
  std::vector<std::string> openings;  // boundary loops of the mesh
};

// All templates, in a fixed order.
const std::vector<TemplateInfo>& Templates();
// nullptr if unknown.
const TemplateInfo* FindTemplate(const std::string& name);

struct TemplateOptions {
  std::string size = "M";      // "S", "M" or "L" preset
  uint64_t seed = 0;           // 0 = the preset proportions; else a perturbed instance
  double edge_length = 0.025;  // metres, target mesh edge length
  double layer_gap = 0.01;     // metres between front and back layer
  double perturbation = 0.05;  // relative: each parameter scaled by U(1−p, 1+p) when seed ≠ 0
  // Explicit parameter values (metres / radians); applied after the preset and the
  // seeded perturbation, so they are exact. Unknown names are an error.
  std::map<std::string, double> params;
  void Validate() const;
};

// The resolved outline of one instance: its parameters, contour (with openings) and
// anchor positions on the pattern.
struct TemplateShape {
  std::string name;
  std::string instance;  // e.g. "pants-M", "pants-M-s3", "pants-M-s3-p1a2b3c4d"
  std::map<std::string, double> params;
  Contour contour;
  std::vector<AnchorSpec> anchors;
};

// Throws drape::Error naming the template, size, or parameter at fault (including
// parameter combinations that give a self-intersecting outline).
TemplateShape MakeTemplateShape(const std::string& template_name, const TemplateOptions& options);

// MakeTemplateShape → GarmentFromContour. Deterministic: same name + options → the
// same mesh bit for bit. `stats` (optional) receives the mesh quality.
Garment MakeGarment(const std::string& template_name, const TemplateOptions& options, MeshStats* stats = nullptr);

}  // namespace drape
