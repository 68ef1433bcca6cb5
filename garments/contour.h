// Contour → two-sided garment mesh (paper §"Folding Pipeline in Simulation"): a closed
// 2D outline is resampled, triangulated inside with a constrained Delaunay
// triangulation refined to a target edge length (CGAL), mirrored into a back layer
// and stitched to the front along the outline except at the openings. An opening may
// have a back edge of its own (Contour::back_openings: a shirt's back neckline is
// higher than the front's): both edges are then constraints of one triangulation, and
// the region between them belongs to one layer only.
// The procedural templates (templates.h) are built through this same code path.
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "garments/garment.h"

namespace drape {

// A closed simple polygon in the pattern plane (metres, y up), given once (the last
// point is NOT repeated). edge_tag[i] labels the edge points[i] → points[i+1 mod n]:
// "" for a seam (front and back stitched), otherwise the name of the opening it
// belongs to ("neck", "hem", "left_cuff", ...). A run of consecutive edges with the
// same non-empty tag is one opening = one boundary loop of the final mesh.
// Either orientation is accepted (clockwise input is reversed).
struct Contour {
  std::vector<Vec2> points;
  std::vector<std::string> edge_tag;  // #points; empty vector = all seams (closed shell)
  // Openings whose back-layer edge differs from the front's (real garments: a shirt's
  // back neckline is higher than the front's, trousers' back waist higher): opening
  // tag → the back edge as a polyline from the opening's first point to its last, in
  // the order of `points`, both included (they are the stitched corners where the
  // opening meets its seams). The back edge must lie wholly outside the outline (the
  // back layer has the extra cloth between the two edges) or wholly inside it (the
  // front has it) and cross nothing. The seams stay shared: stitched vertex to vertex.
  // An opening not named here has the same edge on both layers.
  std::map<std::string, std::vector<Vec2>> back_openings;
};

// A labelled point on the flat pattern; snapped to the nearest front-layer vertex.
struct AnchorSpec {
  std::string label;
  Vec2 uv = Vec2::Zero();  // metres, pattern coordinates
};

struct ContourOptions {
  double edge_length = 0.025;  // target edge length, metres
  double layer_gap = 0.01;     // distance between front (z=+gap/2) and back (z=−gap/2), metres
  // Delaunay_mesher_2 criteria: shape bound B = 1/(4 sin² θmin) → 0.125 is CGAL's
  // best-guaranteed bound (θmin ≈ 20.6°); size bound = size_factor × edge_length on
  // the longest edge of a triangle. size_factor > 1 because refinement leaves most
  // edges well below the bound; 1.4 gives a mean edge close to edge_length.
  double angle_bound = 0.125;
  double size_factor = 1.4;
  // Lloyd-style smoothing iterations of interior vertices after refinement (0 = off).
  int lloyd_iterations = 10;
  void Validate() const;
};

// Quality of the built mesh; edge ratios are relative to ContourOptions::edge_length.
struct MeshStats {
  int vertices = 0, faces = 0;
  int front_vertices = 0;  // vertices of the front layer (interior + boundary)
  int seam_vertices = 0;   // stitched (shared by both layers) boundary vertices
  int boundary_loops = 0;  // == number of openings
  int openings = 0;
  double edge_min = 0, edge_mean = 0, edge_max = 0;  // metres, 2D pattern edges
  double ratio_min = 0, ratio_p05 = 0, ratio_p95 = 0, ratio_max = 0;
  double min_angle_deg = 0;  // smallest triangle angle in the pattern
  double area = 0;           // front-layer pattern area, m²
  int refine_rounds = 0;     // rounds of seam-chord splitting + re-refinement
};

// Builds the garment. category/instance are copied; anchors are snapped to the
// nearest front-layer vertex (layer 0). Layout of the result:
//   uv: the pattern position (x, y) of every vertex (same for both layers);
//   layer: 0 front (incl. stitched seam vertices), 1 back;
//   V: (x, y, +gap/2) front, (x, y, −gap/2) back, (x, y, 0) stitched seam vertices;
//     front vertices first (numbered by first appearance in the front faces), then the
//     back's in order of appearance in the back faces;
//   faces: front counter-clockwise seen from +z, back reversed (outward normals).
// With back_openings, the back layer's pattern is the outline with those openings'
// back edges; each layer is the triangulation of its own pattern (one triangulation
// of both, so the common part is the same on both layers) and a front-opening vertex
// lying inside the back's pattern has a back copy that is interior to the back layer.
// Without back_openings the result is exactly the mirrored-layer garment.
// Throws drape::Error for a bad contour (fewer than 3 points, repeated points,
// self-intersections, zero area, tag count mismatch), naming the point/edge.
Garment GarmentFromContour(const Contour& contour, const std::vector<AnchorSpec>& anchors,
                           const ContourOptions& options, const std::string& category = "custom",
                           const std::string& instance = "", MeshStats* stats = nullptr);

struct MaskOptions {
  double metres_per_pixel = 0.002;
  double simplify_px = 1.0;  // cv::approxPolyDP tolerance, pixels (0 = keep every pixel)
  void Validate() const;
};

// Outer contour of the largest blob of a binary mask (CV_8UC1, non-zero = garment)
// via cv::findContours, in metres: x = (col + 0.5)·mpp, y = (rows − row − 0.5)·mpp
// (y up). All edges are seams. Throws drape::Error if the mask is empty or not 8-bit.
Contour ContourFromMask(const cv::Mat& mask, const MaskOptions& options);

}  // namespace drape
