// Garments: triangle meshes with a flat-pattern parameterisation and labelled anchors
// (the paper's grasp points). Everything downstream (hanging, sensing, recognition,
// registration, folding) starts from a Garment.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "common/mesh.h"

namespace drape {

// A labelled grasp point. Labels are stable snake_case names documented in
// garments/anchors.md (e.g. "left_elbow", "collar", "waist_right").
struct Anchor {
  std::string label;
  Vec2 uv = Vec2::Zero();        // position on the flat pattern, metres
  int vertex = -1;               // index into Garment::mesh.V
  Vec3 position = Vec3::Zero();  // == mesh.V.row(vertex) for the mesh it was made with
};

// A garment as built (flat) or imported. Flat garments lie in the x–y plane with
// y up (collar/waist at the top), front layer at z = +gap/2, back at z = −gap/2;
// the two layers are one connected, manifold mesh stitched along the outline
// except at the openings.
struct Garment {
  std::string category;  // "long_sleeve_shirt", "tshirt", "pants", "shorts", "towel", "skirt", or "custom"
  std::string instance;  // unique name of this instance, e.g. "pants-M-s3"
  TriMesh mesh;
  Points2 uv;              // #V×2, metres on the flat pattern (empty if unknown, e.g. imports)
  std::vector<int> layer;  // #V: 0 front (incl. stitched seam vertices), 1 back (empty if unknown)
  std::vector<Anchor> anchors;

  // nullptr if there is no anchor with that label.
  const Anchor* FindAnchor(std::string_view label) const;
};

}  // namespace drape
