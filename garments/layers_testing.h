// Test helpers: a flat two-layer garment's layers, their boundaries and seams.
#pragma once

#include <algorithm>
#include <map>
#include <set>
#include <utility>

#include "garments/garment.h"

namespace drape::testing {

// What each layer of a flat two-layer garment is made of.
struct LayerSeams {
  double front_area = 0, back_area = 0;                // pattern (uv) areas of the layers' faces
  double front_seam_length = 0, back_seam_length = 0;  // a layer's edges joining two stitched vertices
  int front_seam_edges = 0, back_seam_edges = 0;
  int stitched_edges_not_one_per_layer = 0;      // edges between stitched vertices without one front and one back face
  double front_max_y = -1e9, back_max_y = -1e9;  // highest pattern point of each layer
};

// A face is on the back if it has a back vertex (layer 1), else on the front; stitched
// vertices are those at z = 0 on layer 0.
inline LayerSeams MeasureLayers(const Garment& g) {
  LayerSeams s;
  const auto& F = g.mesh.F;
  auto stitched = [&](int v) { return g.layer[v] == 0 && g.mesh.V(v, 2) == 0; };
  std::map<std::pair<int, int>, std::pair<int, int>> edge_faces;  // (front, back) face counts
  for (int f = 0; f < F.rows(); ++f) {
    bool back = false;
    for (int k = 0; k < 3; ++k) back |= g.layer[F(f, k)] == 1;
    const Vec2 a = g.uv.row(F(f, 0)), b = g.uv.row(F(f, 1)), c = g.uv.row(F(f, 2));
    const double area = 0.5 * std::abs((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
    (back ? s.back_area : s.front_area) += area;
    for (int k = 0; k < 3; ++k) {
      const int u = F(f, k), v = F(f, (k + 1) % 3);
      auto& e = edge_faces[{std::min(u, v), std::max(u, v)}];
      (back ? e.second : e.first) += 1;
      double& top = back ? s.back_max_y : s.front_max_y;
      top = std::max(top, g.uv(u, 1));
    }
  }
  for (const auto& [e, n] : edge_faces) {
    if (!stitched(e.first) || !stitched(e.second)) continue;
    const double len = (Vec2(g.uv.row(e.first)) - Vec2(g.uv.row(e.second))).norm();
    if (n.first > 0) s.front_seam_length += len, ++s.front_seam_edges;
    if (n.second > 0) s.back_seam_length += len, ++s.back_seam_edges;
    if (n.first != 1 || n.second != 1) ++s.stitched_edges_not_one_per_layer;
  }
  return s;
}

}  // namespace drape::testing
