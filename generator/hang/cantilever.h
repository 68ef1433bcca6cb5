// The cantilever bending test (ASTM D1388 option A) on the cloth core, and the heavy
// elastica it is read with.
//
// A strip of fabric lies on a platform with an overhang of length L beyond its edge and
// bends down under its own weight w (N/m², per unit width: w·width per metre). The
// shape of an inextensible strip of bending rigidity B (N·m, per unit width) is the
// heavy elastica: with s the arc length from the edge and θ(s) the angle below the
// horizontal, B·θ''(s) = −w·(L − s)·cos θ, θ(0) = 0 (clamped), θ'(L) = 0 (free end). It
// depends on γ = w·L³/B alone. The lab reports the bending length c = (B/w)^(1/3):
// ASTM D1388 slides the strip until its tip reaches a plane 41.5° below the edge and
// takes c = L/2 (Peirce's approximation); here the simulated strip's tip is read with
// the exact elastica, B = w·L³/γ for the γ whose tip lies where the strip's does.
#pragma once

#include <string>

#include "generator/hang/hang.h"

namespace drape {

struct ElasticaTip {
  double x = 0, y = 0;        // tip position / L: x along the platform, y up (≤ 0)
  double chord_angle = 0;     // rad below the horizontal, edge → tip
  double root_curvature = 0;  // θ'(0)·L
};
// The heavy elastica for γ = w·L³/B ≥ 0 (RK4 shooting on θ'(0), 2,000 steps).
ElasticaTip HeavyElastica(double gamma);
// The γ whose tip chord lies `chord_angle` (rad, in (0, π/2)) below the horizontal.
double ElasticaGammaForChordAngle(double chord_angle);

struct CantileverOptions {
  double width = 0.025;       // m (ASTM D1388: 25 mm)
  double overhang = 0;        // m beyond the platform edge; 0: twice the expected bending length
  double held = 0.03;         // m of strip on the platform (held still: the slide's weight holds it)
  double edge_length = 0.02;  // m, mesh edge (the overhang is a whole number of rows about this long)
  double settle_time = 6;     // s simulated before the tip is read
  void Validate() const;      // throws drape::FieldError naming the field
};

struct CantileverResult {
  double overhang = 0;          // m
  double tip_drop = 0;          // m below the platform
  double chord_angle = 0;       // rad below the horizontal
  double gamma = 0;             // w·L³/B of the elastica with that chord
  double bending_rigidity = 0;  // N·m: w·L³/γ, the strip's effective B
  double bending_length = 0;    // m: (B/w)^(1/3) of that B
  double motion = 0;            // m moved over the last 0.25 s (settled if small)
  int nodes = 0;                // of the strip's mesh
  int substeps = 0;             // Bullet steps per time step (hinge stability)
  std::string failure;          // empty unless the strip blew up
};

// The strip of `material` with `fit`'s simulation constants, on the cloth core with
// `hang`'s solver options (time step, iterations, damping, strain limit).
CantileverResult RunCantilever(const Material& material, const MaterialFit& fit, const HangOptions& hang,
                               const CantileverOptions& options);

}  // namespace drape
