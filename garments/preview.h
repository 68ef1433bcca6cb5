// A picture of a flat garment for people: the front layer filled and meshed, seams
// dark, openings red, anchors as dots with their labels, a scale bar and a title.
#pragma once

#include <string>

#include "garments/garment.h"

namespace drape {

// PNG bytes, width_px wide (height follows the garment's aspect ratio). Uses the
// pattern uv when the garment has it, else the x–y of the vertices; the front layer
// is layer 0 (without layers: faces counter-clockwise on the pattern uv, or without
// uv, faces whose normal points to +z). Deterministic.
std::string RenderFlatPreview(const Garment& garment, int width_px = 800);

}  // namespace drape
