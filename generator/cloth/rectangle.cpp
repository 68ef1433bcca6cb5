#include "generator/cloth/rectangle.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/format.h"

namespace drape {
namespace {

// Two layers share (stitch) the grid points on the left, right and bottom sides.
bool Stitched(int i, int j, int nx) { return i == 0 || i == nx || j == 0; }

// Whether grid cell (i, j) is split along its b–d diagonal, (i + 1, j)–(i, j + 1),
// rather than a–c. Diagonals alternate so the sheet has no preferred shear direction;
// but two layers never take a diagonal between two stitched points (in the bottom
// corner cells): its triangle would have three stitched corners, i.e. be the same
// triangle in both layers, on an edge of four faces (not a manifold; CGAL counts the
// doubled triangle as a self-intersecting pair).
bool DiagonalBD(int i, int j, int nx, bool two_layers) {
  bool bd = (i + j) % 2;
  if (two_layers) {
    const bool ac_stitched = Stitched(i, j, nx) && Stitched(i + 1, j + 1, nx);
    const bool bd_stitched = Stitched(i + 1, j, nx) && Stitched(i, j + 1, nx);
    if (ac_stitched != bd_stitched) bd = ac_stitched;
  }
  return bd;
}

}  // namespace

Garment MakeRectangleGarment(double width, double height, double edge_length, bool two_layers, double gap) {
  if (!(width > 0 && height > 0 && edge_length > 0 && gap >= 0))
    throw Error("MakeRectangleGarment: sizes must be positive");
  const int nx = std::max(1, static_cast<int>(std::lround(width / edge_length)));
  const int ny = std::max(1, static_cast<int>(std::lround(height / edge_length)));
  // One cell across: every grid point is on the left or right seam, the layers coincide.
  if (two_layers && nx < 2)
    throw Error("MakeRectangleGarment: two layers need at least two cells across (width " + FormatNumber(width) +
                " m, edge_length " + FormatNumber(edge_length) + " m)");
  Garment g;
  g.category = "towel";
  g.instance = two_layers ? "rectangle-2" : "rectangle-1";
  std::vector<Vec3> V;
  std::vector<Vec2> UV;
  std::vector<int> layer;
  // id[l][j][i]: vertex of grid point (i, j) on layer l; stitched points share one id.
  std::vector<std::vector<std::vector<int>>> id(2, std::vector<std::vector<int>>(ny + 1, std::vector<int>(nx + 1, -1)));
  auto stitched = [&](int i, int j) { return Stitched(i, j, nx); };
  const int layers = two_layers ? 2 : 1;
  for (int l = 0; l < layers; ++l)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        const double x = width * i / nx - width / 2, y = height * j / ny;
        if (l == 1 && stitched(i, j)) {
          id[1][j][i] = id[0][j][i];
          continue;
        }
        double z = 0;
        if (two_layers && !stitched(i, j)) z = l == 0 ? gap / 2 : -gap / 2;
        id[l][j][i] = static_cast<int>(V.size());
        V.emplace_back(x, y, z);
        UV.emplace_back(x, y);
        layer.push_back(l);
      }
  std::vector<std::array<int, 3>> F;
  for (int l = 0; l < layers; ++l)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const int a = id[l][j][i], b = id[l][j][i + 1], c = id[l][j + 1][i + 1], d = id[l][j + 1][i];
        const bool flip = DiagonalBD(i, j, nx, two_layers);
        std::array<int, 3> t1 = flip ? std::array<int, 3>{a, b, d} : std::array<int, 3>{a, b, c};
        std::array<int, 3> t2 = flip ? std::array<int, 3>{b, c, d} : std::array<int, 3>{a, c, d};
        if (l == 1) {  // back layer wound opposite: normals point outwards (−z)
          std::swap(t1[1], t1[2]);
          std::swap(t2[1], t2[2]);
        }
        F.push_back(t1);
        F.push_back(t2);
      }
  g.mesh.V.resize(V.size(), 3);
  g.uv.resize(V.size(), 2);
  for (size_t i = 0; i < V.size(); ++i) {
    g.mesh.V.row(i) = V[i].transpose();
    g.uv.row(i) = UV[i].transpose();
  }
  g.mesh.F.resize(F.size(), 3);
  for (size_t f = 0; f < F.size(); ++f) g.mesh.F.row(f) << F[f][0], F[f][1], F[f][2];
  g.layer = layer;
  auto anchor = [&](const char* label, int i, int j) {
    Anchor a;
    a.label = label;
    a.vertex = id[0][j][i];
    a.position = g.mesh.V.row(a.vertex).transpose();
    a.uv = g.uv.row(a.vertex).transpose();
    g.anchors.push_back(a);
  };
  anchor("top_left", 0, ny);
  anchor("top_right", nx, ny);
  anchor("bottom_left", 0, 0);
  anchor("bottom_right", nx, 0);
  anchor("top_centre", nx / 2, ny);
  return g;
}

}  // namespace drape
