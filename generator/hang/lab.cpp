#include "generator/hang/lab.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/field_error.h"
#include "common/format.h"
#include "common/rng.h"
#include "garments/contour.h"

namespace drape {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180;

// Pattern (x, y) lying flat: world (x, 0, −y), the pattern's +z normal pointing up.
Vec3 Flat(double x, double y) { return Vec3(x, 0, -y); }

// The lab's cloth: the material's fitted constants, its cloth–cloth friction.
std::shared_ptr<const ClothModel> LabModel(const LabCloth& c, const TriMesh& rest, ClothOptions co) {
  co.collision.cloth_friction = c.fit.cloth_friction;
  return MakeClothModel(rest, {}, ClothMaterialFor(c.material, c.fit, c.hang), co);
}

}  // namespace

TriMesh MeshedSheet(const std::vector<Vec2>& outline, double edge_length) {
  Contour contour;
  contour.points = outline;
  ContourOptions o;
  o.edge_length = edge_length;
  const Garment g = GarmentFromContour(contour, {}, o, "custom", "sheet");
  // The front layer: faces without a back vertex (stitched outline vertices are front).
  std::vector<int> id(g.mesh.NumVertices(), -1);
  std::vector<std::array<int, 3>> faces;
  int n = 0;
  for (int f = 0; f < g.mesh.NumFaces(); ++f) {
    bool front = true;
    for (int k = 0; k < 3; ++k) front &= g.layer[g.mesh.F(f, k)] == 0;
    if (!front) continue;
    std::array<int, 3> t{};
    for (int k = 0; k < 3; ++k) {
      int& v = id[g.mesh.F(f, k)];
      if (v < 0) v = n++;
      t[k] = v;
    }
    faces.push_back(t);
  }
  TriMesh sheet;
  sheet.V.resize(n, 3);
  for (int v = 0; v < g.mesh.NumVertices(); ++v)
    if (id[v] >= 0) sheet.V.row(id[v]) << g.mesh.V(v, 0), g.mesh.V(v, 1), 0;
  sheet.F.resize(static_cast<int>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f) sheet.F.row(static_cast<int>(f)) << faces[f][0], faces[f][1], faces[f][2];
  return sheet;
}

// ---- the Cusick drape test ------------------------------------------------------------

void DrapeOptions::Validate() const {
  if (!(sample_diameter > 0.05 && sample_diameter < 2))
    BadField(sample_diameter, "sample_diameter", "must be in (0.05, 2) m");
  if (!(disc_diameter > 0.01 && disc_diameter < sample_diameter))
    BadField(disc_diameter, "disc_diameter", "must be in (0.01 m, sample_diameter)");
  if (!(edge_length > 0.002 && edge_length < 0.2)) BadField(edge_length, "edge_length", "must be in (0.002, 0.2) m");
  if (seeds.empty()) BadField(seeds, "seeds", "must name at least one seed");
  if (!(jitter >= 0 && jitter < 0.02)) BadField(jitter, "jitter", "must be in [0, 0.02) m");
  if (!(settle_time > 1 && settle_time <= 120)) BadField(settle_time, "settle_time", "must be in (1, 120] s");
  if (!(pixel > 1e-5 && pixel < 0.01)) BadField(pixel, "pixel", "must be in (1e-5, 0.01) m");
  if (!(shadow_window >= 0.6 && shadow_window <= 5)) BadField(shadow_window, "shadow_window", "must be in [0.6, 5] s");
  if (!(shadow_tolerance > 0 && shadow_tolerance < 0.1))
    BadField(shadow_tolerance, "shadow_tolerance", "must be in (0, 0.1)");
  if (!(fold_depth > 0 && fold_depth < 0.1)) BadField(fold_depth, "fold_depth", "must be in (0, 0.1) m");
}

namespace {

// The shadow of a mesh seen from above (world y up) on a raster of `pixel` metres
// centred on the y axis: its area (m²) and its number of lobes (folds).
struct Shadow {
  double area = 0;
  int folds = 0;
};
Shadow MeasureShadow(const Points3& x, const Faces& F, double radius, double pixel, double fold_depth) {
  const int size = static_cast<int>(std::ceil(2.2 * radius / pixel));
  cv::Mat mask = cv::Mat::zeros(size, size, CV_8UC1);
  auto px = [&](int v) {
    return cv::Point(static_cast<int>(std::lround(x(v, 0) / pixel + size / 2.0)),
                     static_cast<int>(std::lround(x(v, 2) / pixel + size / 2.0)));
  };
  for (int f = 0; f < F.rows(); ++f) {
    const cv::Point p[3] = {px(F(f, 0)), px(F(f, 1)), px(F(f, 2))};
    cv::fillConvexPoly(mask, p, 3, cv::Scalar(255));
  }
  Shadow s;
  s.area = cv::countNonZero(mask) * pixel * pixel;
  // Folds: the outline's radius against its angle (the largest radius per degree),
  // smoothed over 5°, and its maxima that stand fold_depth above the valleys on both sides.
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  std::vector<double> r(360, 0.0);
  for (const auto& c : contours)
    for (const cv::Point& p : c) {
      const double dx = (p.x - size / 2.0) * pixel, dz = (p.y - size / 2.0) * pixel;
      int a = static_cast<int>(std::floor((std::atan2(dz, dx) + kPi) / (2 * kPi) * 360)) % 360;
      r[a] = std::max(r[a], std::hypot(dx, dz));
    }
  std::vector<double> sm(360);
  for (int a = 0; a < 360; ++a) {
    double sum = 0;
    for (int k = -2; k <= 2; ++k) sum += r[(a + k + 360) % 360];
    sm[a] = sum / 5;
  }
  // Walk round from the global minimum: a fold is a rise of fold_depth after a valley
  // followed by a fall of fold_depth.
  const int start = static_cast<int>(std::min_element(sm.begin(), sm.end()) - sm.begin());
  double low = sm[start], high = sm[start];
  bool rising = true;
  for (int k = 1; k <= 360; ++k) {
    const double v = sm[(start + k) % 360];
    if (rising) {
      high = std::max(high, v);
      if (high - v >= fold_depth && high - low >= fold_depth) {
        ++s.folds;
        rising = false;
        low = v;
      }
      low = std::min(low, v);
    } else {
      low = std::min(low, v);
      if (v - low >= fold_depth) {
        rising = true;
        high = v;
      }
    }
  }
  return s;
}

}  // namespace

DrapeResult RunDrape(const LabCloth& cloth, const DrapeOptions& o) {
  o.Validate();
  const double R = o.sample_diameter / 2, r_disc = o.disc_diameter / 2;
  std::vector<Vec2> circle;
  const int points = std::max(24, static_cast<int>(std::ceil(2 * kPi * R / (o.edge_length / 4))));
  circle.reserve(points);
  for (int k = 0; k < points; ++k)
    circle.emplace_back(R * std::cos(2 * kPi * k / points), R * std::sin(2 * kPi * k / points));
  const TriMesh pattern = MeshedSheet(circle, o.edge_length);
  TriMesh rest = pattern;
  for (int i = 0; i < rest.NumVertices(); ++i) rest.V.row(i) = Flat(pattern.V(i, 0), pattern.V(i, 1)).transpose();
  const auto model = LabModel(cloth, rest, ClothOptionsFor(cloth.hang, cloth.hang.time_step));
  std::vector<int> clamped;
  for (int i = 0; i < rest.NumVertices(); ++i)
    if (pattern.V.row(i).norm() <= r_disc * (1 + 1e-9)) clamped.push_back(i);
  DrapeResult res;
  res.nodes = rest.NumVertices();
  std::vector<double> coefficients;
  for (const uint64_t seed : o.seeds) {
    ClothWorld w(model, rest.V);
    w.Hold(w.AddGripper(Jaw{}, Eigen::Isometry3d::Identity()), clamped);
    Rng rng(DeriveSeed(seed, "drape/jitter"));
    Points3 dx = Points3::Zero(rest.NumVertices(), 3);
    for (int i = 0; i < dx.rows(); ++i) dx(i, 1) = o.jitter * rng.Uniform(-1, 1);
    w.Perturb(dx);
    const double disc = kPi * r_disc * r_disc, sample = kPi * R * R;
    auto coefficient = [&](Shadow* s) {
      *s = MeasureShadow(w.positions(), rest.F, R, o.pixel, o.fold_depth);
      return (s->area - disc) / (sample - disc);
    };
    // Settled as a lab reads it: when the shadow stops changing (its coefficient moves
    // less than shadow_tolerance over shadow_window), or when no node moves more than
    // 1 mm in 0.25 s. Nodes of a drape keep a 2–3 mm flutter per 0.25 s that leaves
    // the shadow unchanged (tshirt at 2 cm: 0.653 at 12 s and at 30 s).
    DrapeRun run;
    run.seed = seed;
    Shadow s;
    std::vector<double> history;  // the coefficient after each shadow_window
    while (true) {
      SettleOptions so;
      so.distance = 0.001;
      so.min_time = 0.5 * o.shadow_window;
      so.time_cap = o.shadow_window;
      const SettleReport sr = w.Settle(so);
      run.sim_time += sr.sim_time;
      run.motion = sr.motion;
      history.push_back(coefficient(&s));
      if (!sr.settled && !sr.timed_out) {
        run.failure = sr.failure;
        break;
      }
      const size_t n = history.size();
      run.settled = sr.settled ||
                    (n >= 3 && run.sim_time >= 3 && std::abs(history[n - 1] - history[n - 2]) <= o.shadow_tolerance &&
                     std::abs(history[n - 2] - history[n - 3]) <= o.shadow_tolerance);
      if (run.settled || run.sim_time >= o.settle_time - 1e-9) break;
    }
    run.coefficient = history.back();
    run.folds = s.folds;
    if (run.failure.empty()) coefficients.push_back(run.coefficient);
    res.folds.push_back(run.folds);
    res.runs.push_back(run);
  }
  if (!coefficients.empty()) {
    std::sort(coefficients.begin(), coefficients.end());
    const size_t m = coefficients.size();
    res.drape_coefficient = m % 2 ? coefficients[m / 2] : 0.5 * (coefficients[m / 2 - 1] + coefficients[m / 2]);
  }
  return res;
}

// ---- cloth on cloth on an incline --------------------------------------------------------

void InclineOptions::Validate() const {
  if (!(angle_deg >= 0 && angle_deg < 80)) BadField(angle_deg, "angle_deg", "must be in [0, 80) degrees");
  if (!(sheet > 0.02 && sheet < 2)) BadField(sheet, "sheet", "must be in (0.02, 2) m");
  if (!(base > sheet && base < 4)) BadField(base, "base", "must be larger than the sheet and below 4 m");
  if (!(edge_length > 0.002 && edge_length < sheet / 2))
    BadField(edge_length, "edge_length", "must be in (0.002 m, sheet/2)");
  if (!(time > 0 && time <= 60)) BadField(time, "time", "must be in (0, 60] s");
}

InclineResult RunIncline(const LabCloth& cloth, const InclineOptions& o) {
  o.Validate();
  const Garment lower = MakeRectangleGarment(o.base, o.base, o.edge_length, false);
  const Garment upper = MakeRectangleGarment(o.sheet, o.sheet, o.edge_length, false);
  const int nl = lower.mesh.NumVertices(), nu = upper.mesh.NumVertices();
  const ClothOptions co = ClothOptionsFor(cloth.hang, cloth.hang.time_step);
  const double t = co.collision.thickness;
  // Both sheets flat on a plane through the origin tilted about z; the sliding sheet
  // centred on the fixed one, one layer thickness above it. The rest mesh is this start
  // (the two sheets' distance at rest is what repulsion keeps them apart by).
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(o.angle_deg * kDeg, Vec3::UnitZ()).toRotationMatrix();
  TriMesh both;
  both.V.resize(nl + nu, 3);
  both.F.resize(lower.mesh.NumFaces() + upper.mesh.NumFaces(), 3);
  for (int i = 0; i < nl + nu; ++i) {
    const bool up = i >= nl;
    const Garment& g = up ? upper : lower;
    const int k = up ? i - nl : i;
    const double half = (up ? o.sheet : o.base) / 2;
    both.V.row(i) = (tilt * (Flat(g.mesh.V(k, 0), g.mesh.V(k, 1) - half) + Vec3(0, up ? t : 0, 0))).transpose();
  }
  both.F << lower.mesh.F, (upper.mesh.F.array() + nl).matrix();
  const auto model = LabModel(cloth, both, co);
  InclineResult res;
  res.friction = model->options.collision.cloth_friction;
  ClothWorld w(model, both.V);
  std::vector<int> fixed(nl);
  for (int i = 0; i < nl; ++i) fixed[i] = i;
  w.Hold(w.AddGripper(Jaw{}, Eigen::Isometry3d::Identity()), fixed);
  auto centroid = [&] { return Vec3(w.positions().bottomRows(nu).colwise().mean().transpose()); };
  while (w.time() < 0.25) w.Step();
  const Vec3 c0 = centroid();
  // Past the base's edge the sheet falls: its fall is no sliding distance, so the run
  // stops there and says so.
  const Vec3 normal = tilt * Vec3::UnitY();
  while (w.time() < 0.25 + o.time) {
    w.Step();
    const Vec3 d = centroid() - c0;
    if ((d - d.dot(normal) * normal).norm() >= o.base / 2) {
      res.slid_off = true;
      res.off_time = w.time() - 0.25;
      break;
    }
  }
  res.failure = w.Health();
  res.slide = (centroid() - c0).norm();
  return res;
}

// ---- a crease's recovery -------------------------------------------------------------

void CreaseOptions::Validate() const {
  if (!(length > 0.02 && length < 2)) BadField(length, "length", "must be in (0.02, 2) m");
  if (!(width > 0.01 && width < 2)) BadField(width, "width", "must be in (0.01, 2) m");
  if (!(edge_length > 0.002 && edge_length < length / 4))
    BadField(edge_length, "edge_length", "must be in (0.002 m, length/4)");
  if (!(press_time >= 0 && press_time <= 60)) BadField(press_time, "press_time", "must be in [0, 60] s");
  if (!(recovery_time > 0 && recovery_time <= 60)) BadField(recovery_time, "recovery_time", "must be in (0, 60] s");
}

CreaseOptions CreaseOptionsAt(double edge_length) {
  CreaseOptions o;
  o.edge_length = edge_length;
  o.length = std::max(o.length, 5 * edge_length);
  o.width = std::max(o.width, 2 * edge_length);
  return o;
}

CreaseResult RunCrease(const LabCloth& cloth, const CreaseOptions& o) {
  o.Validate();
  // An even number of cells along the length: a row of nodes on the fold line x = 0.
  const int cells = 2 * std::max(2, static_cast<int>(std::lround(o.length / (2 * o.edge_length))));
  const Garment strip = MakeRectangleGarment(o.width, o.length, o.length / cells, false);
  // The pattern runs along y from 0 to length: folded at y = length/2. World: the
  // clamped leg lies along −x at height 0, the free leg folded back over it one layer
  // thickness higher, the fold line between them at half that height.
  ClothOptions co = ClothOptionsFor(cloth.hang, cloth.hang.time_step);
  co.gravity = Vec3::Zero();
  const double t = co.collision.thickness, mid = o.length / 2;
  const int n = strip.mesh.NumVertices();
  TriMesh rest = strip.mesh, folded = strip.mesh;
  std::vector<int> all(n), clamped, fold_row, clamped_end, free_end;
  const double eps = 1e-9 * o.length;
  for (int i = 0; i < n; ++i) {
    const double u = strip.mesh.V(i, 0), s = strip.mesh.V(i, 1) - mid;  // s < 0: clamped leg
    rest.V.row(i) << s, 0, u;
    folded.V.row(i) << -std::abs(s), s > eps ? t : (s < -eps ? 0 : t / 2), u;
    all[i] = i;
    if (s <= eps) clamped.push_back(i);
    if (std::abs(s) <= eps) fold_row.push_back(i);
    if (s <= -mid + eps) clamped_end.push_back(i);
    if (s >= mid - eps) free_end.push_back(i);
  }
  const auto model = LabModel(cloth, rest, co);
  ClothWorld w(model, folded.V);
  CreaseResult res;
  const int press = w.AddGripper(Jaw{}, Eigen::Isometry3d::Identity());
  w.Hold(press, all);
  while (w.time() < o.press_time - 1e-9) w.Step();
  double largest = 0;
  for (int h = 0; h < w.bending().rest_angle.size(); ++h)
    largest = std::max(largest, std::abs(w.bending().rest_angle[h]));
  res.rest_angle = largest / kDeg;
  w.Open(press);
  w.Hold(w.AddGripper(Jaw{}, Eigen::Isometry3d::Identity()), clamped);
  const double t1 = w.time() + o.recovery_time;
  while (w.time() < t1 - 1e-9) w.Step();
  res.failure = w.Health();
  auto mean = [&](const std::vector<int>& ids) {
    Vec3 c = Vec3::Zero();
    for (int i : ids) c += w.positions().row(i).transpose();
    return Vec3(c / static_cast<double>(ids.size()));
  };
  const Vec3 hinge = mean(fold_row), a = mean(clamped_end) - hinge, b = mean(free_end) - hinge;
  res.open_angle = std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
  return res;
}

}  // namespace drape
