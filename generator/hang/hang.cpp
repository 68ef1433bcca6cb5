#include "generator/hang/hang.h"

#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <BulletSoftBody/btSoftBody.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>

#include "common/error.h"
#include "common/format.h"
#include "common/field_error.h"
#include "common/rng.h"
#include "generator/hang/equilibrium.h"

namespace drape {

void HangOptions::Validate() const {
  auto bad = [](const auto& field, const char* name, const std::string& what) { BadField(field, name, what); };
  if (!(time_step > 1e-5 && time_step <= 1.0 / 30)) bad(time_step, "time_step", "must be in (1e-5, 1/30] s");
  if (solver_iterations < 1 || solver_iterations > 100) bad(solver_iterations, "solver_iterations", "must be in [1, 100]");
  if (!(damping >= 0 && damping < 1)) bad(damping, "damping", "must be in [0, 1)");
  if (!(layer_thickness > 0 && layer_thickness < 0.05)) bad(layer_thickness, "layer_thickness", "must be in (0, 0.05) m");
  if (!(settle_distance > 0)) bad(settle_distance, "settle_distance", "must be > 0");
  if (!(settle_window >= 4 * time_step)) bad(settle_window, "settle_window", "must be >= 4 time steps");
  if (!(min_time >= 0)) bad(min_time, "min_time", "must be >= 0");
  if (!(time_cap > min_time + settle_window)) bad(time_cap, "time_cap", "must exceed min_time + settle_window");
  if (!(jaw_width > 0 && jaw_width < 0.5)) bad(jaw_width, "jaw_width", "must be in (0, 0.5) m");
  if (!(jitter >= 0 && jitter < 0.01)) bad(jitter, "jitter", "must be in [0, 0.01) m");
  if (!(max_speed > 0)) bad(max_speed, "max_speed", "must be > 0");
  if (!(equilibrium_tolerance > 0 && equilibrium_tolerance < 1)) bad(equilibrium_tolerance, "equilibrium_tolerance", "must be in (0, 1)");
  if (!(equilibrium_max_displacement > 0)) bad(equilibrium_max_displacement, "equilibrium_max_displacement", "must be > 0");
  if (equilibrium_iterations < 1) bad(equilibrium_iterations, "equilibrium_iterations", "must be >= 1");
  if (!(equilibrium_rescue_motion >= 0)) bad(equilibrium_rescue_motion, "equilibrium_rescue_motion", "must be >= 0 m");
  if (equilibrium_rescue_iterations < 1) bad(equilibrium_rescue_iterations, "equilibrium_rescue_iterations", "must be >= 1");
  if (!(fit_width > 0.05 && fit_height > 0.05)) bad(fit_width, "fit_width/fit_height", "must be > 0.05 m");
  if (!(fit_edge_length > 0.002 && fit_edge_length < 0.2)) bad(fit_edge_length, "fit_edge_length", "must be in (0.002, 0.2) m");
  if (!(fit_tolerance_percent > 0)) bad(fit_tolerance_percent, "fit_tolerance_percent", "must be > 0");
  if (fit_max_iterations < 2) bad(fit_max_iterations, "fit_max_iterations", "must be >= 2");
}

// ---------------------------------------------------------------------------------
// Test/reference garments.

double ShearFraction(const TriMesh& hung, const Points3& flat, const Vec3& flat_grasp) {
  int lowest = 0;
  for (int i = 1; i < hung.NumVertices(); ++i)
    if (hung.V(i, 1) < hung.V(lowest, 1)) lowest = i;
  const double l1 = hung.V.row(lowest).norm();
  const double l2 = (flat.row(lowest).transpose() - flat_grasp).norm();
  return (l1 - l2) / l2;
}

namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

// Springs of the model shared by Bullet (links) and the equilibrium solve.
struct ClothModel {
  std::vector<std::array<int, 2>> stretch;  // mesh edges
  std::vector<double> stretch_area;         // area of the adjacent faces / 3... per edge, m²
  std::vector<std::array<int, 2>> bend;     // opposite vertices across interior edges
  std::vector<double> bend_area;
  std::vector<double> mass;                 // kg per node
};

ClothModel BuildModel(const TriMesh& mesh, double area_density) {
  ClothModel m;
  const Eigen::VectorXd area = FaceAreas(mesh);
  m.mass.assign(mesh.NumVertices(), 0.0);
  for (int f = 0; f < mesh.NumFaces(); ++f)
    for (int c = 0; c < 3; ++c) m.mass[mesh.F(f, c)] += area_density * area[f] / 3;
  const EdgeTopology topo = BuildEdgeTopology(mesh);
  auto opposite = [&](int f, int a, int b) {
    for (int c = 0; c < 3; ++c)
      if (mesh.F(f, c) != a && mesh.F(f, c) != b) return mesh.F(f, c);
    return -1;
  };
  for (const EdgeFaces& e : topo.edges) {
    double a = area[e.faces[0]] / 3;
    if (e.faces[1] >= 0) a += area[e.faces[1]] / 3;
    m.stretch.push_back(e.edge);
    m.stretch_area.push_back(a);
    if (e.faces[1] >= 0) {
      const int c = opposite(e.faces[0], e.edge[0], e.edge[1]);
      const int d = opposite(e.faces[1], e.edge[0], e.edge[1]);
      if (c >= 0 && d >= 0 && c != d) {
        m.bend.push_back({std::min(c, d), std::max(c, d)});
        m.bend_area.push_back(a);
      }
    }
  }
  return m;
}

SpringNetwork MakeNetwork(const ClothModel& model, const Points3& rest, double membrane,
                          double bending, const std::vector<char>& fixed) {
  SpringNetwork net;
  net.mass = model.mass;
  net.fixed = fixed;
  auto add = [&](const std::array<int, 2>& s, double area, double rel) {
    const double l0 = (rest.row(s[0]) - rest.row(s[1])).norm();
    if (l0 <= 0) return;
    net.springs.push_back(s);
    net.rest_length.push_back(l0);
    // A membrane of stiffness Y (N/m) stretched by ε carries Y·ε per metre of width;
    // an edge represents a strip of width ≈ area/L0.
    net.stiffness.push_back(rel * membrane * area / l0);
  };
  for (size_t i = 0; i < model.stretch.size(); ++i) add(model.stretch[i], model.stretch_area[i], 1.0);
  for (size_t i = 0; i < model.bend.size(); ++i) add(model.bend[i], model.bend_area[i], bending);
  return net;
}

// Proximity pass keeping layers and folds apart: each node against the triangles not
// within two rings of it; a node closer than `thickness` to a triangle it projects onto
// is pushed back to the side it was on before the step (Gauss–Seidel, fixed order).
class Separator {
 public:
  Separator(const TriMesh& mesh, double thickness) : F_(mesh.F), h_(thickness) {
    const auto nbr = VertexNeighbours(mesh);
    near_.resize(mesh.NumVertices());
    for (int i = 0; i < mesh.NumVertices(); ++i) {
      std::vector<int>& s = near_[i];
      s.push_back(i);
      for (int a : nbr[i]) {
        s.push_back(a);
        for (int b : nbr[a]) s.push_back(b);
      }
      std::sort(s.begin(), s.end());
      s.erase(std::unique(s.begin(), s.end()), s.end());
    }
    double sum = 0;
    for (const auto& e : UniqueEdges(mesh)) sum += (mesh.V.row(e[0]) - mesh.V.row(e[1])).norm();
    cell_ = std::max(sum / std::max<size_t>(1, UniqueEdges(mesh).size()), 3 * h_);
  }

  // x, v: Bullet nodes (updated); prev: positions before the step. Returns corrections.
  int Apply(btSoftBody* sb, const std::vector<Vec3>& prev) {
    const int n = sb->m_nodes.size();
    const int nf = static_cast<int>(F_.rows());
    auto X = [&](int i) {
      const btVector3& p = sb->m_nodes[i].m_x;
      return Vec3(p.x(), p.y(), p.z());
    };
    // Grid of triangle boxes (inflated by h) into hashed cells, CSR by counting sort.
    const size_t buckets = 1u << 14;
    auto key = [&](int cx, int cy, int cz) {
      uint64_t k = static_cast<uint64_t>(cx) * 73856093u ^ static_cast<uint64_t>(cy) * 19349663u ^
                   static_cast<uint64_t>(cz) * 83492791u;
      return static_cast<size_t>(k & (buckets - 1));
    };
    auto cell = [&](double c) { return static_cast<int>(std::floor(c / cell_)); };
    start_.assign(buckets + 1, 0);
    box_.resize(nf);
    normal_.resize(nf);
    auto& box = box_;
    for (int f = 0; f < nf; ++f) {
      // Unit normal once per face per step: most candidates are rejected by their
      // plane distance before the (costlier) neighbourhood test.
      const Vec3 xa = X(F_(f, 0));
      Vec3 nn = (X(F_(f, 1)) - xa).cross(X(F_(f, 2)) - xa);
      const double nl = nn.norm();
      normal_[f] = nl > 1e-12 ? Vec3(nn / nl) : Vec3::Zero();
      Vec3 lo = X(F_(f, 0)), hi = lo;
      for (int c = 1; c < 3; ++c) {
        lo = lo.cwiseMin(X(F_(f, c)));
        hi = hi.cwiseMax(X(F_(f, c)));
      }
      lo.array() -= h_;
      hi.array() += h_;
      box[f] = {cell(lo.x()), cell(lo.y()), cell(lo.z()), cell(hi.x()), cell(hi.y()), cell(hi.z())};
      for (int a = box[f][0]; a <= box[f][3]; ++a)
        for (int b = box[f][1]; b <= box[f][4]; ++b)
          for (int c = box[f][2]; c <= box[f][5]; ++c) ++start_[key(a, b, c) + 1];
    }
    for (size_t k = 0; k < buckets; ++k) start_[k + 1] += start_[k];
    items_.assign(start_[buckets], 0);
    fill_.assign(start_.begin(), start_.end() - 1);
    for (int f = 0; f < nf; ++f)
      for (int a = box[f][0]; a <= box[f][3]; ++a)
        for (int b = box[f][1]; b <= box[f][4]; ++b)
          for (int c = box[f][2]; c <= box[f][5]; ++c) items_[fill_[key(a, b, c)]++] = f;

    int corrections = 0;
    for (int i = 0; i < n; ++i) {
      btSoftBody::Node& node = sb->m_nodes[i];
      const Vec3 p0 = X(i);
      const size_t k = key(cell(p0.x()), cell(p0.y()), cell(p0.z()));
      for (int it = start_[k]; it < start_[k + 1]; ++it) {
        const int f = items_[it];
        const int a = F_(f, 0), b = F_(f, 1), c = F_(f, 2);
        const Vec3 p = X(i), xa = X(a);
        const Vec3 nrm = normal_[f];
        if (nrm.isZero()) continue;
        const double s = (p - xa).dot(nrm);
        if (std::abs(s) >= h_) continue;
        const auto& nr = near_[i];
        if (std::binary_search(nr.begin(), nr.end(), a) || std::binary_search(nr.begin(), nr.end(), b) ||
            std::binary_search(nr.begin(), nr.end(), c))
          continue;
        const Vec3 xb = X(b), xc = X(c);
        // Barycentric coordinates of the projection; only nodes over the triangle.
        const Vec3 q = p - s * nrm;
        const Vec3 v0 = xb - xa, v1 = xc - xa, v2 = q - xa;
        const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
        const double den = d00 * d11 - d01 * d01;
        if (den <= 0) continue;
        const double wb = (d11 * d20 - d01 * d21) / den, wc = (d00 * d21 - d01 * d20) / den, wa = 1 - wb - wc;
        if (wa < -0.01 || wb < -0.01 || wc < -0.01) continue;
        // Side before the step (previous positions).
        Vec3 n0 = (prev[b] - prev[a]).cross(prev[c] - prev[a]);
        const double s0 = (prev[i] - prev[a]).dot(n0);
        if (s0 == 0) continue;
        const double side = s0 > 0 ? 1.0 : -1.0;
        // Closer than h: stop approaching (velocity); closer than h/2 or crossed: also
        // move back to h/2. (Pushing every contact out to h each step fought the links
        // and left the layers jittering at ~0.2 m/s.)
        const double gap = side * s;
        if (gap >= h_) continue;
        btSoftBody::Node* tri[3] = {&sb->m_nodes[a], &sb->m_nodes[b], &sb->m_nodes[c]};
        const double w[3] = {wa, wb, wc};
        double denom = node.m_im;
        for (int t = 0; t < 3; ++t) denom += w[t] * w[t] * tri[t]->m_im;
        if (denom <= 0) continue;
        const Vec3 dir = side * nrm;
        auto bt = [](const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); };
        if (gap < h_ / 2) {
          const double lambda = (h_ / 2 - gap) / denom;
          node.m_x += bt(lambda * node.m_im * dir);
          for (int t = 0; t < 3; ++t) tri[t]->m_x -= bt(lambda * w[t] * tri[t]->m_im * dir);
        }
        // Remove the approaching relative normal velocity (inelastic contact).
        Vec3 vrel(node.m_v.x(), node.m_v.y(), node.m_v.z());
        for (int t = 0; t < 3; ++t) vrel -= w[t] * Vec3(tri[t]->m_v.x(), tri[t]->m_v.y(), tri[t]->m_v.z());
        const double vn = vrel.dot(dir);
        if (vn < 0) {
          const double mu = -vn / denom;
          node.m_v += bt(mu * node.m_im * dir);
          for (int t = 0; t < 3; ++t) tri[t]->m_v -= bt(mu * w[t] * tri[t]->m_im * dir);
        }
        ++corrections;
      }
    }
    return corrections;
  }

  // Node–triangle pairs closer than `radius` in state x (node over the triangle, not
  // within two rings): the equilibrium solve's contacts, each kept at `gap` on its side.
  std::vector<SpringNetwork::Contact> Contacts(const Points3& x, double radius, double gap) const {
    std::vector<SpringNetwork::Contact> out;
    const int nf = static_cast<int>(F_.rows());
    std::vector<std::pair<double, int>> order(nf);
    double reach = 0;
    for (int f = 0; f < nf; ++f) {
      double lo = x(F_(f, 0), 0), hi = lo;
      for (int c = 1; c < 3; ++c) {
        lo = std::min(lo, x(F_(f, c), 0));
        hi = std::max(hi, x(F_(f, c), 0));
      }
      order[f] = {lo, f};
      reach = std::max(reach, hi - lo);
    }
    std::sort(order.begin(), order.end());
    for (int i = 0; i < x.rows(); ++i) {
      const Vec3 p = x.row(i).transpose();
      auto it = std::lower_bound(order.begin(), order.end(), std::make_pair(p.x() - reach - radius, -1));
      for (; it != order.end() && it->first <= p.x() + radius; ++it) {
        const int f = it->second;
        const int a = F_(f, 0), b = F_(f, 1), c = F_(f, 2);
        const auto& nr = near_[i];
        if (std::binary_search(nr.begin(), nr.end(), a) || std::binary_search(nr.begin(), nr.end(), b) ||
            std::binary_search(nr.begin(), nr.end(), c))
          continue;
        const Vec3 xa = x.row(a), xb = x.row(b), xc = x.row(c);
        Vec3 nrm = (xb - xa).cross(xc - xa);
        if (nrm.norm() < 1e-12) continue;
        nrm.normalize();
        const double sd = (p - xa).dot(nrm);
        if (std::abs(sd) >= radius || sd == 0) continue;
        const Vec3 q = p - sd * nrm, v0 = xb - xa, v1 = xc - xa, v2 = q - xa;
        const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
        const double den = d00 * d11 - d01 * d01;
        if (den <= 0) continue;
        const double wb = (d11 * d20 - d01 * d21) / den, wc = (d00 * d21 - d01 * d20) / den, wa = 1 - wb - wc;
        if (wa < 0 || wb < 0 || wc < 0) continue;
        out.push_back({i, {a, b, c}, Vec3(wa, wb, wc), sd > 0 ? nrm : Vec3(-nrm), gap});
      }
    }
    return out;
  }

 private:
  Faces F_;
  double h_;
  double cell_;
  std::vector<std::vector<int>> near_;
  std::vector<int> start_, items_, fill_;
  std::vector<std::array<int, 6>> box_;
  std::vector<Vec3> normal_;
};

struct RunOutcome {
  bool ok = false;
  bool timed_out = false;  // ran to time_cap without settling (no blow-up)
  std::string failure;
  Points3 x;  // final positions (object frame)
  HangStats stats;
};

// One Bullet run at time step dt.
RunOutcome RunBullet(const TriMesh& mesh, const Points3& start, const Points3& rest,
                     const ClothModel& model, const std::vector<char>& fixed, double link_k,
                     double bending, const HangOptions& opt, double dt, uint64_t seed) {
  RunOutcome out;
  const int n = mesh.NumVertices();
  btSoftBodyRigidBodyCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btSoftRigidDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  const btVector3 gravity(0, -9.81f, 0);
  world.setGravity(gravity);
  btSoftBodyWorldInfo& info = world.getWorldInfo();
  info.m_gravity = gravity;  // setGravity does not reach the soft-body world info
  info.air_density = 0;
  info.m_sparsesdf.Initialize();
  info.m_sparsesdf.setDefaultVoxelsz(0.01);

  std::vector<btVector3> x(n);
  std::vector<btScalar> m(n);
  for (int i = 0; i < n; ++i) {
    // Links take their rest length from the positions at creation: create at rest.
    x[i] = btVector3(btScalar(rest(i, 0)), btScalar(rest(i, 1)), btScalar(rest(i, 2)));
    m[i] = btScalar(model.mass[i]);
  }
  auto sb = std::make_unique<btSoftBody>(&info, n, x.data(), m.data());
  btSoftBody::Material* stretch_mat = sb->m_materials[0];
  stretch_mat->m_kLST = btScalar(link_k);
  stretch_mat->m_kAST = stretch_mat->m_kVST = 1;
  btSoftBody::Material* bend_mat = sb->appendMaterial();
  bend_mat->m_kLST = btScalar(std::clamp(link_k * bending, 1e-4, 1.0));
  bend_mat->m_kAST = bend_mat->m_kVST = 1;
  for (const auto& e : model.stretch) sb->appendLink(e[0], e[1], stretch_mat);
  for (const auto& e : model.bend) sb->appendLink(e[0], e[1], bend_mat);
  for (int f = 0; f < mesh.NumFaces(); ++f) sb->appendFace(mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2), stretch_mat);
  sb->m_cfg.piterations = opt.solver_iterations;
  // kDP removes that fraction of the velocity every step: keep the damping per second
  // the same at a retry's smaller step (the same kDP per half step doubles the drag, and
  // over-damped slow modes then creep even slower).
  const double kdp = 1 - std::pow(1 - opt.damping, dt / opt.time_step);
  sb->m_cfg.kDP = btScalar(kdp);
  sb->m_cfg.collisions = 0;  // nothing rigid to touch; self contact is ours
  sb->getCollisionShape()->setMargin(0.002f);
  for (int i = 0; i < n; ++i)
    if (fixed[i]) sb->setMass(i, 0);
  // Move to the start pose (rigid transform of rest + seeded jitter) keeping rest lengths.
  for (int i = 0; i < n; ++i) {
    btSoftBody::Node& nd = sb->m_nodes[i];
    nd.m_x = btVector3(btScalar(start(i, 0)), btScalar(start(i, 1)), btScalar(start(i, 2)));
    nd.m_q = nd.m_x;
    nd.m_v.setZero();
  }
  world.addSoftBody(sb.get());

  std::unique_ptr<Separator> sep;
  if (opt.self_collision) sep = std::make_unique<Separator>(mesh, opt.layer_thickness);

  const int window = std::max(4, static_cast<int>(std::lround(opt.settle_window / dt)));
  const int quarter = std::max(1, window / 4);
  const int max_steps = static_cast<int>(std::ceil(opt.time_cap / dt));
  const int min_steps = static_cast<int>(std::ceil(opt.min_time / dt));
  // Snapshots every quarter window; settled when now vs 4 snapshots ago moved < tol.
  std::vector<std::vector<Vec3>> ring;
  std::vector<Vec3> prev(n);
  double total_mass = std::accumulate(model.mass.begin(), model.mass.end(), 0.0);
  const double extent = (start.colwise().maxCoeff() - start.colwise().minCoeff()).norm();
  const double energy_cap = 50 * total_mass * 9.81 * std::max(extent, 0.1);
  double bullet_s = 0;
  int step = 0;
  bool settled = false;
  std::string failure;
  auto pos = [&](int i) {
    const btVector3& p = sb->m_nodes[i].m_x;
    return Vec3(p.x(), p.y(), p.z());
  };
  for (step = 1; step <= max_steps; ++step) {
    for (int i = 0; i < n; ++i) prev[i] = pos(i);
    const auto t0 = Clock::now();
    world.stepSimulation(btScalar(dt), 0, btScalar(dt));
    bullet_s += Seconds(t0, Clock::now());
    if (sep) {
      const auto t1 = Clock::now();
      out.stats.collision_corrections = sep->Apply(sb.get(), prev);
      out.stats.contact_seconds += Seconds(t1, Clock::now());
    }
    if (step % quarter == 0) {
      double ke = 0, vmax = 0;
      bool finite = true;
      for (int i = 0; i < n; ++i) {
        const btSoftBody::Node& nd = sb->m_nodes[i];
        if (!std::isfinite(nd.m_x.x() + nd.m_x.y() + nd.m_x.z() + nd.m_v.x() + nd.m_v.y() + nd.m_v.z())) {
          finite = false;
          break;
        }
        const double v2 = nd.m_v.length2();
        vmax = std::max(vmax, std::sqrt(v2));
        ke += 0.5 * model.mass[i] * v2;
      }
      if (!finite) { failure = "NaN in the simulation state"; break; }
      if (vmax > opt.max_speed) { failure = "blew up: node speed " + FormatNumber(vmax) + " m/s"; break; }
      if (ke > energy_cap) { failure = "blew up: kinetic energy " + FormatNumber(ke) + " J"; break; }
      std::vector<Vec3> snap(n);
      for (int i = 0; i < n; ++i) snap[i] = pos(i);
      ring.push_back(std::move(snap));
      if (ring.size() > 5) ring.erase(ring.begin());
      if (ring.size() == 5 && step >= min_steps) {
        double moved = 0;
        for (int i = 0; i < n; ++i) moved = std::max(moved, (ring.back()[i] - ring.front()[i]).norm());
        out.stats.settle_motion = moved;

        if (moved < opt.settle_distance) { settled = true; break; }
      }
    }
  }
  out.stats.steps = std::min(step, max_steps);
  out.stats.sim_time = out.stats.steps * dt;
  out.stats.time_step = dt;
  out.stats.bullet_seconds = bullet_s;
  out.stats.settled = settled;
  out.x.resize(n, 3);
  double ke = 0, vmax = 0;
  for (int i = 0; i < n; ++i) {
    out.x.row(i) = pos(i).transpose();
    const double v2 = sb->m_nodes[i].m_v.length2();
    ke += 0.5 * model.mass[i] * v2;
    vmax = std::max(vmax, std::sqrt(v2));
  }
  out.stats.kinetic_energy = ke;
  out.stats.max_speed = vmax;
  world.removeSoftBody(sb.get());
  if (failure.empty() && !out.x.allFinite()) failure = "NaN in the simulation state";
  if (failure.empty() && !settled) {
    failure = "not settled within time_cap " + FormatNumber(opt.time_cap) + " s (still moving " +
              FormatNumber(out.stats.settle_motion) + " m per settle_window)";
    out.timed_out = true;
  }
  out.failure = failure;
  out.ok = failure.empty();
  (void)seed;
  return out;
}

double Strain(const ClothModel& model, const Points3& rest, const Points3& x, double* max_out) {
  double sum = 0, mx = -1;
  for (const auto& e : model.stretch) {
    const double l0 = (rest.row(e[0]) - rest.row(e[1])).norm();
    const double s = (x.row(e[0]) - x.row(e[1])).norm() / l0 - 1;
    sum += s;
    mx = std::max(mx, s);
  }
  *max_out = mx;
  return model.stretch.empty() ? 0 : sum / model.stretch.size();
}

}  // namespace

HangResult Hang(const Garment& garment, int anchor_vertex, const Vec3& grasp_offset,
                const Material& material, const MaterialFit& fit, const HangOptions& options,
                uint64_t seed) {
  const auto wall0 = Clock::now();
  options.Validate();
  material.Validate();
  const TriMesh& mesh = garment.mesh;
  const int n = mesh.NumVertices();
  if (n < 3 || mesh.NumFaces() < 1) throw Error("hang: garment '" + garment.instance + "' has no mesh");
  if (anchor_vertex < 0 || anchor_vertex >= n)
    throw Error("hang: anchor vertex " + std::to_string(anchor_vertex) + " out of range for garment '" +
                garment.instance + "' (" + std::to_string(n) + " vertices)");
  if (!(fit.stiffness > 0 && fit.stiffness <= 1)) throw Error("hang: MaterialFit.stiffness must be in (0, 1]");
  if (options.equilibrium_solve && !(fit.spring_stiffness > 0))
    throw Error("hang: MaterialFit.spring_stiffness must be > 0 (run FitMaterial)");
  if (!mesh.V.allFinite()) throw Error("hang: garment '" + garment.instance + "' has non-finite vertices");

  const Points3& rest = mesh.V;
  const Vec3 grasp = rest.row(anchor_vertex).transpose() + Vec3(grasp_offset.x(), grasp_offset.y(), 0);
  const ClothModel model = BuildModel(mesh, material.area_density);

  // Held nodes: within jaw_width/2 of the grasp point on the flat garment (both layers,
  // as a pinch does), at least the nearest node.
  std::vector<char> fixed(n, 0);
  HangResult result;
  int nearest = 0;
  for (int i = 0; i < n; ++i) {
    const double d = (rest.row(i).transpose() - grasp).norm();
    if (d <= options.jaw_width / 2) fixed[i] = 1;
    if (d < (rest.row(nearest).transpose() - grasp).norm()) nearest = i;
  }
  fixed[nearest] = 1;
  // Jaws narrower than the mesh would hold a single node: the garment could then spin
  // about the vertical (a zero-stiffness mode that Bullet's Gauss–Seidel link solve
  // drives slowly and never settles), while real jaws hold a patch. Hold the one ring.
  if (std::count(fixed.begin(), fixed.end(), 1) < 3) {
    const auto ring = VertexNeighbours(mesh);
    for (int v : ring[nearest]) fixed[v] = 1;
  }
  for (int i = 0; i < n; ++i)
    if (fixed[i]) result.held_vertices.push_back(i);

  // Start pose: the flat garment (vertical, in the x–y plane) turned about z so that its
  // centre of mass is straight below the grasp point, grasp point at the origin.
  Vec3 com = Vec3::Zero();
  double mtot = 0;
  for (int i = 0; i < n; ++i) {
    com += model.mass[i] * rest.row(i).transpose();
    mtot += model.mass[i];
  }
  com /= mtot;
  const Vec2 d(com.x() - grasp.x(), com.y() - grasp.y());
  const double angle = d.norm() > 1e-9 ? std::atan2(d.x(), -d.y()) : 0.0;  // rotate d onto −y
  const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix();
  Rng rng(DeriveSeed(seed, "hang/jitter"));
  Points3 start(n, 3);
  for (int i = 0; i < n; ++i) {
    Vec3 p = R * (rest.row(i).transpose() - grasp);
    if (!fixed[i]) p += options.jitter * Vec3(rng.Uniform(-1, 1), rng.Uniform(-1, 1), rng.Uniform(-1, 1));
    start.row(i) = p.transpose();
  }
  // Rest state in the object frame (rigidly moved): what the links are created with.
  Points3 rest_obj(n, 3);
  for (int i = 0; i < n; ++i) rest_obj.row(i) = (R * (rest.row(i).transpose() - grasp)).transpose();

  // KINSOL on the spring model (+ contact penalty) from Bullet's state x_in. Fills the
  // equilibrium fields of `st`; returns the state to keep (x_in when not applied).
  auto equilibrate = [&](const Points3& x_in, int iterations, HangStats& st, bool* converged) {
    Points3 x = x_in;
    *converged = false;
    SpringNetwork net = MakeNetwork(model, rest, fit.spring_stiffness, material.bending_stiffness, fixed);
    if (options.self_collision && options.equilibrium_solve) {
      // Layers resting on each other: keep them apart in the solve too (the spring
      // model alone lets them pass through).
      Separator sep(mesh, options.layer_thickness);
      net.contacts = sep.Contacts(x, 2 * options.layer_thickness, options.layer_thickness / 2);
      double ksum = 0;
      for (size_t i = 0; i < net.springs.size(); ++i) ksum += net.stiffness[i] / net.rest_length[i];
      net.contact_stiffness = 10 * ksum / std::max<size_t>(1, net.springs.size());
    }
    EquilibriumReport eq;
    const auto teq = Clock::now();
    if (options.equilibrium_solve) {
      EquilibriumOptions eo;
      eo.relative_tolerance = options.equilibrium_tolerance;
      eo.max_displacement = options.equilibrium_max_displacement;
      eo.max_total_iterations = iterations;
      Points3 solved = x;
      eq = SolveEquilibrium(net, solved, eo);
      if (eq.applied && options.self_collision) {
        // The spring model has no contact: reject a solve that pushes layers through.
        int crossings = 0;
        for (const auto& c : net.contacts) {
          Vec3 q = solved.row(c.node).transpose();
          for (int j = 0; j < 3; ++j) q -= c.w[j] * solved.row(c.tri[j]).transpose();
          crossings += c.dir.dot(q) < 0;
        }
        if (crossings > std::max(2, n / 100)) {
          eq.applied = false;
          eq.message = "rejected: " + std::to_string(crossings) + " node/triangle crossings";
          eq.residual_after = eq.residual_before;
          eq.relative_after = eq.relative_before;
        } else {
          x = solved;
        }
      } else if (eq.applied) {
        x = solved;
      }
      st.bullet_force_residual_rel = eq.relative_before;
      st.force_residual = eq.residual_after;
      st.force_residual_rel = eq.relative_after;
      st.equilibrium_applied = eq.applied;
      st.equilibrium_converged = eq.applied && eq.converged;
      st.equilibrium_iterations = eq.iterations;
      st.equilibrium_displacement = eq.max_displacement;
      st.equilibrium_message = eq.message;
      st.equilibrium_seconds += Seconds(teq, Clock::now());
      *converged = st.equilibrium_converged;
    } else {
      const Points3 f = SpringForces(net, x);
      double amax = 0, rmax = 0;
      for (int i = 0; i < n; ++i)
        if (!fixed[i]) {
          amax = std::max(amax, f.row(i).norm());
          rmax = std::max(rmax, f.row(i).norm() / (9.81 * net.mass[i]));
        }
      st.force_residual = amax;
      st.force_residual_rel = st.bullet_force_residual_rel = rmax;
      st.equilibrium_message = "not requested";
    }
    return x;
  };

  RunOutcome run;
  int retries = 0;
  double dt = options.time_step;
  const bool can_rescue = options.equilibrium_solve && fit.spring_stiffness > 0 &&
                          options.equilibrium_rescue_motion > 0;
  bool rescued = false;
  Points3 x;
  for (int attempt = 0; attempt < 2; ++attempt) {
    run = RunBullet(mesh, start, rest_obj, model, fixed, fit.stiffness, material.bending_stiffness, options, dt, seed);
    if (run.ok) break;
    // Reached the time cap barely creeping: if the static problem from this state
    // converges, that is the stationary state Bullet was creeping towards.
    if (run.timed_out && can_rescue && run.stats.settle_motion <= options.equilibrium_rescue_motion) {
      HangStats st = run.stats;
      bool converged = false;
      Points3 solved = equilibrate(run.x, options.equilibrium_rescue_iterations, st, &converged);
      if (converged) {
        run.stats = st;
        run.stats.settled_by_equilibrium = true;
        x = solved;
        rescued = true;
        break;
      }
      run.stats.equilibrium_seconds = st.equilibrium_seconds;
      run.failure += "; equilibrium rescue: " + st.equilibrium_message;
    }
    if (attempt == 0) {
      ++retries;
      dt /= 2;  // smaller step: stiffer, more stable
    }
  }
  result.stats = run.stats;
  result.stats.retries = retries;
  if (!run.ok && !rescued) {
    result.ok = false;
    result.failure = run.failure + " (after retry at time_step " + FormatNumber(dt) + " s)";
    result.mesh.F = mesh.F;
    result.mesh.V = run.x.allFinite() ? run.x : start;
    result.stats.wall_seconds = Seconds(wall0, Clock::now());
    return result;
  }
  if (!rescued) {
    x = run.x;
    bool converged = false;
    if (fit.spring_stiffness > 0) x = equilibrate(run.x, options.equilibrium_iterations, result.stats, &converged);
  }
  result.stats.strain_mean = Strain(model, rest, x, &result.stats.strain_max);
  result.mesh.V = x;
  result.mesh.F = mesh.F;
  result.ok = true;
  result.stats.wall_seconds = Seconds(wall0, Clock::now());
  return result;
}

}  // namespace drape
