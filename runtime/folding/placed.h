// The garment as `drape unfold` leaves it on its table, read by `drape fold`. An unfold
// trial that placed its garment flat writes, into its trial folder:
//   placed.json  {"format": "drape-placed-1", "category": C, "instance": I,
//                 "garment": "garment.ply", "lying": "lying.ply", "layer": [0, 1, …],
//                 "material": preset name, "stiffness": kLST, "friction": μ}
//   garment.ply (+ garment.anchors.json)  the pattern mesh (rest shape, ExportGarment)
//   lying.ply    the same vertices as the garment lies (world frame, y up, metres)
// and names placed.json in its trace.json ("placed_garment"). stiffness and friction
// are the material fit the trial's cloth had (the release's record at its mesh's edge).
#pragma once

#include <filesystem>
#include <string>

#include "garments/garment.h"

namespace drape::folding {

struct PlacedGarment {
  Garment garment;       // flat pattern (rest shape), anchors, layers
  Points3 lying;         // #V×3, world frame of the table it lies on
  std::string material;  // material preset name
  double stiffness = 0;  // Bullet link kLST of the fit
  double friction = 0;   // Coulomb μ on the table
};

// Writes placed.json, garment.ply (+ anchors) and lying.ply into `dir` (created).
void WritePlacedGarment(const std::filesystem::path& dir, const PlacedGarment& placed);

// True if `path` is a trial folder (with placed.json or trace.json), a placed.json or a
// trace.json.
bool IsPlacedGarmentPath(const std::filesystem::path& path);

// Reads a placed garment from a trial folder, its placed.json or its trace.json. Throws
// drape::Error naming the file and what is wrong (a trial that did not place its
// garment, a missing file, meshes whose vertices do not correspond).
PlacedGarment ReadPlacedGarment(const std::filesystem::path& path);

}  // namespace drape::folding
