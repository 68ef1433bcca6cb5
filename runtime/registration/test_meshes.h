// Small synthetic meshes for the registration tests and benchmark (no garment library
// needed): a subdivided sphere, a wavy sheet, a flattened two-layer tube (a garment-like
// "bag" open at both ends), and a smooth deformation field.
#pragma once

#include "common/mesh.h"

namespace drape::registration::testing {

// Icosphere with `subdivisions` 1:4 splits, radius r, centred at the origin.
TriMesh IcoSphere(int subdivisions, double r);
// nx × ny vertex grid over [0, w] × [0, h] in x–y, z = amp · sin(2πx/w) cos(πy/h).
TriMesh WavySheet(int nx, int ny, double w, double h, double amp);
// Tube of width w (x), height h (y, hanging below the origin), flattened to thickness t
// (z), n_around × n_down vertices; open at top and bottom.
TriMesh FlatTube(int n_around, int n_down, double w, double h, double t);
// A smooth, moderately large deformation: x + amp·(sin(ωy+1), sin(ωz+2), sin(ωx+3)).
Points3 SmoothDeform(const Points3& V, double amp, double omega);

}  // namespace drape::registration::testing
