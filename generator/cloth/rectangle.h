// A rectangle garment: the reference cloth of material fits and of the cloth tests.
#pragma once

#include "garments/garment.h"

namespace drape {

// width × height (m) in the x–y plane, y up, vertex grid at about edge_length.
// two_layers: front z=+gap/2 and back z=−gap/2 stitched on the left, right and bottom
// sides (open at the top, a pillow case); otherwise one sheet at z=0. Anchors
// "top_left", "top_right", "bottom_left", "bottom_right", "top_centre". A manifold mesh
// (no triangle of three stitched points). Throws drape::Error on non-positive sizes and
// on two layers less than two cells across.
Garment MakeRectangleGarment(double width, double height, double edge_length, bool two_layers, double gap = 0.01);

}  // namespace drape
