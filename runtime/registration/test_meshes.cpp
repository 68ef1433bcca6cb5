#include "runtime/registration/test_meshes.h"

#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace drape::registration::testing {

TriMesh IcoSphere(int subdivisions, double r) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (Vec3& p : v) p.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> g;
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f = g;
  }
  TriMesh m;
  m.V.resize(v.size(), 3);
  for (size_t i = 0; i < v.size(); ++i) m.V.row(i) = r * v[i].transpose();
  m.F.resize(f.size(), 3);
  for (size_t i = 0; i < f.size(); ++i) m.F.row(i) << f[i][0], f[i][1], f[i][2];
  return m;
}

TriMesh WavySheet(int nx, int ny, double w, double h, double amp) {
  TriMesh m;
  m.V.resize(Eigen::Index{nx} * ny, 3);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = w * i / (nx - 1), y = h * j / (ny - 1);
      m.V.row(j * nx + i) << x, y, amp * std::sin(2 * M_PI * x / w) * std::cos(M_PI * y / h);
    }
  m.F.resize(2 * Eigen::Index{nx - 1} * (ny - 1), 3);
  int k = 0;
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      // Alternate the diagonal so the sheet has no preferred direction.
      if ((i + j) % 2 == 0) {
        m.F.row(k++) << a, b, d;
        m.F.row(k++) << a, d, c;
      } else {
        m.F.row(k++) << a, b, c;
        m.F.row(k++) << b, d, c;
      }
    }
  return m;
}

TriMesh FlatTube(int n_around, int n_down, double w, double h, double t) {
  TriMesh m;
  m.V.resize(Eigen::Index{n_around} * n_down, 3);
  for (int j = 0; j < n_down; ++j)
    for (int i = 0; i < n_around; ++i) {
      const double phi = 2 * M_PI * i / n_around;
      const double y = -h * j / (n_down - 1);
      // A slight flare towards the bottom, so the shape is not symmetric in y.
      const double flare = 1 + 0.3 * j / (n_down - 1);
      m.V.row(j * n_around + i) << 0.5 * w * flare * std::cos(phi), y, 0.5 * t * std::sin(phi);
    }
  m.F.resize(2 * Eigen::Index{n_around} * (n_down - 1), 3);
  int k = 0;
  for (int j = 0; j + 1 < n_down; ++j)
    for (int i = 0; i < n_around; ++i) {
      const int i1 = (i + 1) % n_around;
      const int a = j * n_around + i, b = j * n_around + i1, c = a + n_around, d = b + n_around;
      m.F.row(k++) << a, c, d;
      m.F.row(k++) << a, d, b;
    }
  return m;
}

Points3 SmoothDeform(const Points3& V, double amp, double omega) {
  Points3 out = V;
  for (int i = 0; i < V.rows(); ++i) {
    const double x = V(i, 0), y = V(i, 1), z = V(i, 2);
    out(i, 0) += amp * std::sin(omega * y + 1);
    out(i, 1) += amp * std::sin(omega * z + 2);
    out(i, 2) += amp * std::sin(omega * x + 3);
  }
  return out;
}

}  // namespace drape::registration::testing
