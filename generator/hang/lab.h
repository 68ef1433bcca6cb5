// A textile lab on the cloth core (`drape fabric`): the standard tests a lab holds a
// fabric to, run on the simulated cloth of a material at a mesh edge length, each
// reporting the figure the lab reports. The cantilever bending test is in cantilever.h.
//   - drape:   the Cusick drape test (BS 5058 / ISO 9073-9): a 30 cm disc of fabric
//              clamped between two 18 cm discs drapes under its weight; the drape
//              coefficient is the share of the annulus its shadow covers. Real drape is
//              multistable (the number of folds changes from test to test), so it runs
//              over seeds.
//   - incline: a 20 × 20 cm sheet lying on a sheet of the same fabric fixed to a plane
//              tilted by a given angle: how far it slides in 5 s.
//   - crease:  a 20 × 10 cm strip folded 180° across its length, pressed 2 s, released
//              with one leg clamped and no gravity (as the AATCC 66 recovery instrument
//              keeps the free leg vertical): the angle between its legs 5 s later
//              (0: still folded, 180: flat).
// Units: metres, seconds, degrees where named.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "generator/hang/hang.h"

namespace drape {

// What every lab test runs on: the material, its fitted simulation constants and the
// cloth core's solver options (time step, iterations, damping, strain limit, thickness).
struct LabCloth {
  Material material;
  MaterialFit fit;
  HangOptions hang;
};

// A single flat sheet bounded by `outline` (x–y plane, metres), meshed as the garments
// are (garments/contour.h: CGAL's constrained Delaunay triangulation refined to
// edge_length), counter-clockwise seen from +z, at z = 0.
TriMesh MeshedSheet(const std::vector<Vec2>& outline, double edge_length);

struct DrapeOptions {
  double sample_diameter = 0.30;  // m (BS 5058)
  double disc_diameter = 0.18;    // m, the clamping discs
  double edge_length = 0.02;      // m
  std::vector<uint64_t> seeds = {1, 2, 3, 4, 5};
  double jitter = 0.002;    // m: seeded vertical perturbation of the flat sample
  double settle_time = 12;  // s simulated at most
  // Settled when the coefficient moved less than shadow_tolerance in each of the last
  // two shadow_windows (after 3 s), or no node moved more than 1 mm in 0.25 s.
  double shadow_window = 1;         // s
  double shadow_tolerance = 0.002;  // drape coefficient
  double pixel = 0.001;             // m: the shadow's raster
  double fold_depth = 0.003;        // m: a lobe of the shadow's outline this much beyond its valleys is a fold
  void Validate() const;            // throws drape::FieldError naming the field
};
struct DrapeRun {
  uint64_t seed = 0;
  double coefficient = 0;  // (shadow − disc) / (sample − disc)
  int folds = 0;
  bool settled = false;
  double motion = 0;    // m: the largest node move over the last settle window
  double sim_time = 0;  // s simulated
  std::string failure;  // empty unless the run blew up
};
struct DrapeResult {
  double drape_coefficient = 0;  // median over the settled runs
  std::vector<int> folds;        // per seed
  std::vector<DrapeRun> runs;
  int nodes = 0;
};
DrapeResult RunDrape(const LabCloth& cloth, const DrapeOptions& options);

struct InclineOptions {
  double angle_deg = 20;      // tilt of the plane
  double sheet = 0.20;        // m, side of the sliding sheet
  double base = 0.30;         // m, side of the fixed sheet under it
  double edge_length = 0.02;  // m
  double time = 5;            // s of sliding measured (after 0.25 s to land)
  void Validate() const;      // throws drape::FieldError naming the field
};
struct InclineResult {
  double slide = 0;       // m the sheet's centroid moved over the fixed one (until it slid off)
  double friction = 0;    // the cloth–cloth Coulomb μ simulated
  bool slid_off = false;  // its centroid passed the base's edge (base/2 along the plane): the run stops
  double off_time = 0;    // s of sliding until then
  std::string failure;
};
InclineResult RunIncline(const LabCloth& cloth, const InclineOptions& options);

struct CreaseOptions {
  double length = 0.20;       // m, folded at the middle across this
  double width = 0.10;        // m
  double edge_length = 0.02;  // m
  double press_time = 2;      // s held folded
  double recovery_time = 5;   // s after release
  void Validate() const;      // throws drape::FieldError naming the field
};
struct CreaseResult {
  double open_angle = 0;  // degrees between the legs after the recovery
  double rest_angle = 0;  // degrees: the largest hinge rest angle the press left (the crease)
  std::string failure;
};
CreaseResult RunCrease(const LabCloth& cloth, const CreaseOptions& options);
// The crease test at a mesh edge length: the 20 × 10 cm strip, longer and wider where
// the edge needs it (at least 5 × 2 edges), so that coarse garment meshes can be tested
// and fitted (the recovery is the fold's own: the legs' length does not enter it).
CreaseOptions CreaseOptionsAt(double edge_length);

}  // namespace drape
