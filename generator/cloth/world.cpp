#include "generator/cloth/world.h"

#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/format.h"
#include "common/timing.h"

namespace drape {

namespace {

[[noreturn]] void Bad(const char* where, const char* field, const std::string& what) {
  throw Error(std::string(where) + ": " + field + " " + what);
}

btVector3 Bt(double x, double y, double z) { return btVector3(btScalar(x), btScalar(y), btScalar(z)); }

}  // namespace

void ClothMaterial::Validate() const {
  if (!(area_density > 0 && area_density <= 10)) Bad("cloth material", "area_density", "must be in (0, 10] kg/m²");
  if (!(link_stiffness > 0 && link_stiffness <= 1)) Bad("cloth material", "link_stiffness", "must be in (0, 1]");
  if (!(bending > 0 && bending <= 1)) Bad("cloth material", "bending", "must be in (0, 1]");
  if (!std::isfinite(max_strain) || max_strain > 10) Bad("cloth material", "max_strain", "must be ≤ 10 (≤ 0: off)");
  if (!(bending_rigidity >= 0 && bending_rigidity <= 1))
    Bad("cloth material", "bending_rigidity", "must be in [0, 1] N·m (0: Bullet's bending links)");
  if (!(bending_scale > 0 && bending_scale <= 100)) Bad("cloth material", "bending_scale", "must be in (0, 100]");
  if (!(crease_yield >= 0 && std::isfinite(crease_yield)))
    Bad("cloth material", "crease_yield", "must be ≥ 0 1/m (0: no creases)");
  if (!(crease_weakening >= 0 && crease_weakening <= 1000))
    Bad("cloth material", "crease_weakening", "must be in [0, 1000]");
}

void ClothOptions::Validate() const {
  if (!(time_step > 1e-5 && time_step <= 1.0 / 30)) Bad("cloth options", "time_step", "must be in (1e-5, 1/30] s");
  if (solver_iterations < 1 || solver_iterations > 100)
    Bad("cloth options", "solver_iterations", "must be in [1, 100]");
  if (!(damping >= 0 && damping < 1)) Bad("cloth options", "damping", "must be in [0, 1)");
  if (!gravity.allFinite()) Bad("cloth options", "gravity", "must be finite");
  if (!(max_speed > 0)) Bad("cloth options", "max_speed", "must be > 0");
  if (!(air_density >= 0 && air_density <= 1000)) Bad("cloth options", "air_density", "must be in [0, 1000] kg/m³");
  if (!(drag_coefficient >= 0 && drag_coefficient <= 10))
    Bad("cloth options", "drag_coefficient", "must be in [0, 10]");
  collision.Validate();
}

void Jaw::Validate() const {
  if (!(opening > 0 && opening < 1)) Bad("jaw", "opening", "must be in (0, 1) m");
  if (!(pad_length > 0 && pad_length < 1)) Bad("jaw", "pad_length", "must be in (0, 1) m");
  if (!(pad_width > 0 && pad_width < 1)) Bad("jaw", "pad_width", "must be in (0, 1) m");
}

void SettleOptions::Validate() const {
  if (!(distance > 0)) Bad("settle", "distance", "must be > 0 m");
  if (!(window > 0)) Bad("settle", "window", "must be > 0 s");
  if (!(min_time >= 0)) Bad("settle", "min_time", "must be >= 0 s");
  if (!(time_cap > min_time + window)) Bad("settle", "time_cap", "must exceed min_time + window");
  if (ccd_test_cap < 0) Bad("settle", "ccd_test_cap", "must be >= 0 (0: no cap)");
}

void GripperPath::Validate() const {
  if (times.size() != poses.size()) Bad("gripper path", "poses", "must have one pose per time");
  for (size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i])) Bad("gripper path", "times", "must be finite");
    if (i > 0 && !(times[i] > times[i - 1])) Bad("gripper path", "times", "must be strictly increasing");
    if (!poses[i].matrix().allFinite()) Bad("gripper path", "poses", "must be finite");
  }
}

Eigen::Isometry3d GripperPath::Pose(double t) const {
  DRAPE_CHECK(!times.empty(), "GripperPath::Pose on an empty path");
  if (t <= times.front()) return poses.front();
  if (t >= times.back()) return poses.back();
  const size_t k = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
  const double s = (t - times[k - 1]) / (times[k] - times[k - 1]);
  const Eigen::Quaterniond q0(poses[k - 1].linear()), q1(poses[k].linear());
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = q0.slerp(s, q1).toRotationMatrix();
  out.translation() = (1 - s) * poses[k - 1].translation() + s * poses[k].translation();
  return out;
}

std::shared_ptr<const ClothModel> MakeClothModel(const TriMesh& rest, const std::vector<int>& layer,
                                                 const ClothMaterial& material, const ClothOptions& options) {
  material.Validate();
  options.Validate();
  const int n = rest.NumVertices();
  if (n < 3 || rest.NumFaces() < 1) throw Error("cloth model: the mesh has no faces");
  if (!rest.V.allFinite()) throw Error("cloth model: the mesh has non-finite vertices");
  if (rest.F.minCoeff() < 0 || rest.F.maxCoeff() >= n) throw Error("cloth model: a face index is out of range");
  if (!layer.empty() && static_cast<int>(layer.size()) != n)
    throw Error("cloth model: layer has " + std::to_string(layer.size()) + " entries for " + std::to_string(n) +
                " vertices");
  auto m = std::make_shared<ClothModel>();
  m->rest = rest;
  m->layer = layer;
  m->material = material;
  m->options = options;
  m->options.collision.max_strain = material.max_strain;
  const Eigen::VectorXd area = FaceAreas(rest);
  m->mass = Eigen::VectorXd::Zero(n);
  for (int f = 0; f < rest.NumFaces(); ++f)
    for (int c = 0; c < 3; ++c) m->mass[rest.F(f, c)] += material.area_density * area[f] / 3;
  for (int i = 0; i < n; ++i)
    if (!(m->mass[i] > 0))
      throw Error("cloth model: vertex " + std::to_string(i) + " has no area (unused or degenerate)");
  m->total_mass = m->mass.sum();
  m->extent = (rest.V.colwise().maxCoeff() - rest.V.colwise().minCoeff()).norm();
  const EdgeTopology topo = BuildEdgeTopology(rest);
  auto opposite = [&](int f, int a, int b) {
    for (int c = 0; c < 3; ++c)
      if (rest.F(f, c) != a && rest.F(f, c) != b) return rest.F(f, c);
    return -1;
  };
  const bool hinges = material.bending_rigidity > 0;
  for (const EdgeFaces& e : topo.edges) {
    m->stretch_links.push_back(e.edge);
    if (e.faces[1] < 0 || hinges) continue;
    const int c = opposite(e.faces[0], e.edge[0], e.edge[1]), d = opposite(e.faces[1], e.edge[0], e.edge[1]);
    if (c >= 0 && d >= 0 && c != d) m->bend_links.push_back({std::min(c, d), std::max(c, d)});
  }
  if (hinges) {
    BendingOptions bo;
    bo.rigidity = material.bending_rigidity;
    bo.scale = material.bending_scale;
    bo.yield_curvature = material.crease_yield;
    bo.weakening = material.crease_weakening;
    m->bending = MakeBendingModel(rest, layer, bo);
    const double lambda = BendingFrequencySquared(m->bending, InitialBendingState(m->bending), rest.V, m->mass);
    m->bending_frequency = std::sqrt(lambda);
    // Symplectic Euler is stable below 2/√λ; half of that leaves room for triangles
    // the motion squeezes (a hinge's stiffness grows as 1/height²).
    m->substeps = std::max(1, static_cast<int>(std::ceil(options.time_step * m->bending_frequency - 1e-9)));
    if (m->substeps > 64)
      throw Error("cloth model: hinge bending needs " + std::to_string(m->substeps) +
                  " Bullet steps per time step (more than 64): the mesh is too fine or the cloth too stiff for "
                  "time_step " +
                  FormatNumber(options.time_step) + " s");
  }
  return m;
}

// Bullet's objects for one garment: nothing is shared between worlds.
struct ClothWorld::Bullet {
  btSoftBodyRigidBodyCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btSoftRigidDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  std::unique_ptr<btSoftBody> body;
  ~Bullet() {
    if (body) world.removeSoftBody(body.get());
  }
};

ClothWorld::ClothWorld(std::shared_ptr<const ClothModel> model, const Points3& start) : model_(std::move(model)) {
  DRAPE_CHECK(model_ != nullptr, "ClothWorld without a model");
  const ClothModel& m = *model_;
  const int n = m.rest.NumVertices();
  if (start.rows() != n || !start.allFinite())
    throw Error("cloth world: start positions must be finite, " + std::to_string(n) + "×3");
  x_ = start;
  v_ = Points3::Zero(n, 3);
  bend_ = InitialBendingState(m.bending);
  holder_.assign(n, -1);
  const ClothOptions& o = m.options;
  kdp_ = o.damping;

  bullet_ = std::make_unique<Bullet>();
  const btVector3 g = Bt(o.gravity.x(), o.gravity.y(), o.gravity.z());
  bullet_->world.setGravity(g);
  btSoftBodyWorldInfo& info = bullet_->world.getWorldInfo();
  info.m_gravity = g;  // setGravity does not reach the soft-body world info
  info.air_density = btScalar(o.air_density);
  info.m_sparsesdf.Initialize();
  std::vector<btVector3> xb(n);
  std::vector<btScalar> mb(n);
  for (int i = 0; i < n; ++i) {
    // Links take their rest length from the positions at creation: create at rest.
    xb[i] = Bt(m.rest.V(i, 0), m.rest.V(i, 1), m.rest.V(i, 2));
    mb[i] = btScalar(m.mass[i]);
  }
  bullet_->body = std::make_unique<btSoftBody>(&info, n, xb.data(), mb.data());
  btSoftBody* sb = bullet_->body.get();
  btSoftBody::Material* stretch = sb->m_materials[0];
  stretch->m_kLST = btScalar(m.material.link_stiffness);
  stretch->m_kAST = stretch->m_kVST = 1;
  btSoftBody::Material* bend = sb->appendMaterial();
  bend->m_kLST = btScalar(std::clamp(m.material.link_stiffness * m.material.bending, 1e-6, 1.0));
  bend->m_kAST = bend->m_kVST = 1;
  for (const auto& e : m.stretch_links) sb->appendLink(e[0], e[1], stretch);
  for (const auto& e : m.bend_links) sb->appendLink(e[0], e[1], bend);
  for (int f = 0; f < m.rest.NumFaces(); ++f) sb->appendFace(m.rest.F(f, 0), m.rest.F(f, 1), m.rest.F(f, 2), stretch);
  sb->m_cfg.piterations = o.solver_iterations;
  // The world damps the velocity once per time step itself (Step); Bullet's own damping
  // would act again between sub-steps (with one Bullet step per time step its damped
  // velocity is never read).
  sb->m_cfg.kDP = btScalar(m.substeps > 1 ? 0.0 : kdp_);
  // Air drag on the faces (ClothOptions::drag_coefficient); kDG 0 leaves Bullet's
  // aerodynamics off altogether.
  sb->m_cfg.aeromodel = btSoftBody::eAeroModel::F_TwoSidedLiftDrag;
  sb->m_cfg.kDG = btScalar(o.drag_coefficient);
  sb->m_cfg.kLF = 0;
  sb->m_cfg.collisions = 0;  // soft-soft and soft-rigid contact are the handler's
  sb->getCollisionShape()->setMargin(0.002f);
  bullet_->world.addSoftBody(sb);
  SyncBullet();
  if (o.collisions) handler_ = std::make_unique<CollisionHandler>(m.rest.F, m.rest.V, m.options.collision);
}

ClothWorld::~ClothWorld() = default;

void ClothWorld::SyncBullet() {
  btSoftBody* sb = bullet_->body.get();
  for (int i = 0; i < x_.rows(); ++i) {
    btSoftBody::Node& nd = sb->m_nodes[i];
    nd.m_x = Bt(x_(i, 0), x_(i, 1), x_(i, 2));
    nd.m_q = nd.m_x;
    nd.m_v = Bt(v_(i, 0), v_(i, 1), v_(i, 2));
    nd.m_f.setZero();
    // Only on a change: setMass makes Bullet refresh its link constants.
    if ((nd.m_im == 0) != (holder_[i] >= 0)) sb->setMass(i, holder_[i] >= 0 ? btScalar(0) : btScalar(model_->mass[i]));
  }
  // Air drag reads the face normals Bullet computed at its last step's end: with hinge
  // bending take them from this state instead, so that a restored state (SetState) steps
  // as it did the first time. (Bullet's bending links keep the normals of Bullet's own
  // positions: the published releases were built that way; the presets move to hinges
  // with a new release version.)
  if (model_->options.drag_coefficient > 0 && !model_->bending.hinges.empty()) sb->updateNormals();
}

int ClothWorld::AddCollider(const BoxCollider& box) {
  box.Validate();
  colliders_.push_back(box);
  return static_cast<int>(colliders_.size()) - 1;
}

int ClothWorld::AddGripper(const Jaw& jaw, const Eigen::Isometry3d& pose) {
  jaw.Validate();
  if (!pose.matrix().allFinite()) throw Error("cloth world: gripper pose must be finite");
  Gripper g;
  g.jaw = jaw;
  g.pose = pose;
  grippers_.push_back(std::move(g));
  return static_cast<int>(grippers_.size()) - 1;
}

namespace {
void CheckGripper(int g, int count) {
  if (g < 0 || g >= count) throw Error("cloth world: no gripper " + std::to_string(g));
}
}  // namespace

void ClothWorld::SetPath(int gripper, const GripperPath& path) {
  CheckGripper(gripper, NumGrippers());
  path.Validate();
  grippers_[gripper].path = path;
}

void ClothWorld::PlaceGripper(int gripper, const Eigen::Isometry3d& pose) {
  CheckGripper(gripper, NumGrippers());
  Gripper& g = grippers_[gripper];
  if (g.closed) throw Error("cloth world: gripper " + std::to_string(gripper) + " is closed; open it to place it");
  g.pose = pose;
  g.path = GripperPath{};
}

Eigen::Isometry3d ClothWorld::PoseAt(const Gripper& g, double t) const {
  return g.path.times.empty() ? g.pose : g.path.Pose(t);
}

Eigen::Isometry3d ClothWorld::GripperPose(int gripper) const {
  CheckGripper(gripper, NumGrippers());
  return grippers_[gripper].pose;
}

GraspReport ClothWorld::Close(int gripper) {
  CheckGripper(gripper, NumGrippers());
  const Gripper& g = grippers_[gripper];
  const Eigen::Isometry3d inv = g.pose.inverse();
  const Vec3 half(g.jaw.opening / 2, g.jaw.pad_length / 2, g.jaw.pad_width / 2);
  std::vector<int> inside;
  for (int i = 0; i < x_.rows(); ++i) {
    const Vec3 p = inv * Vec3(x_.row(i).transpose());
    if ((p.cwiseAbs().array() <= half.array()).all()) inside.push_back(i);
  }
  return Hold(gripper, inside);
}

GraspReport ClothWorld::Hold(int gripper, const std::vector<int>& nodes) {
  CheckGripper(gripper, NumGrippers());
  for (int i : nodes)
    if (i < 0 || i >= x_.rows())
      throw Error("cloth world: Hold: node " + std::to_string(i) + " is not one of " + std::to_string(x_.rows()));
  Gripper& g = grippers_[gripper];
  for (int i : nodes) {
    if (holder_[i] >= 0) continue;
    holder_[i] = gripper;
    g.held.push_back(i);
  }
  std::sort(g.held.begin(), g.held.end());
  const Eigen::Isometry3d inv = g.pose.inverse();
  g.local.resize(static_cast<Eigen::Index>(g.held.size()), 3);
  for (size_t k = 0; k < g.held.size(); ++k) g.local.row(k) = (inv * Vec3(x_.row(g.held[k]).transpose())).transpose();
  g.closed = !g.held.empty();
  GraspReport r;
  r.nodes = static_cast<int>(g.held.size());
  r.miss = g.held.empty();
  r.node_ids = g.held;
  if (!model_->layer.empty()) {
    for (int i : g.held) r.layers.push_back(model_->layer[i]);
    std::sort(r.layers.begin(), r.layers.end());
    r.layers.erase(std::unique(r.layers.begin(), r.layers.end()), r.layers.end());
  }
  SyncBullet();
  return r;
}

void ClothWorld::Open(int gripper) {
  CheckGripper(gripper, NumGrippers());
  Gripper& g = grippers_[gripper];
  for (int i : g.held) holder_[i] = -1;
  g.held.clear();
  g.local.resize(0, 3);
  g.closed = false;
  SyncBullet();
}

bool ClothWorld::IsClosed(int gripper) const {
  CheckGripper(gripper, NumGrippers());
  return grippers_[gripper].closed;
}

const std::vector<int>& ClothWorld::HeldNodes(int gripper) const {
  CheckGripper(gripper, NumGrippers());
  return grippers_[gripper].held;
}

void ClothWorld::Perturb(const Points3& dx) {
  if (dx.rows() != x_.rows() || !dx.allFinite()) throw Error("cloth world: Perturb needs a finite #V×3 displacement");
  Points3 x1 = x_;
  for (int i = 0; i < x_.rows(); ++i)
    if (holder_[i] < 0) x1.row(i) += dx.row(i);
  if (handler_) {
    Eigen::VectorXd im(x_.rows());
    for (int i = 0; i < x_.rows(); ++i) im[i] = holder_[i] >= 0 ? 0.0 : 1 / model_->mass[i];
    AddCollisionTimings(handler_->Apply(x_, x1, im, model_->options.time_step, colliders_));
  }
  x_ = x1;
  SyncBullet();
}

void ClothWorld::AddCollisionTimings(const CollisionReport& rep) {
  timings_.collision_seconds += rep.total_seconds;
  timings_.broad_seconds += rep.broad_seconds;
  timings_.strain_seconds += rep.strain_seconds;
  timings_.proximity_seconds += rep.proximity_seconds;
  timings_.collider_seconds += rep.collider_seconds;
  timings_.ccd_seconds += rep.ccd_seconds;
  timings_.zone_seconds += rep.zone_seconds;
}

// Bullet's part of a step: the held nodes' velocities that carry them to their place at
// the step's end, then substeps Bullet steps (with the hinge force before each). x1 gets
// Bullet's positions with the held nodes exactly in place; with sub-steps *vb gets
// Bullet's velocities at the step's end.
void ClothWorld::StepBullet(const std::vector<Eigen::Isometry3d>& pose1, Points3& x1, Points3* vb) {
  const ClothModel& m = *model_;
  const double dt = m.options.time_step;
  btSoftBody* sb = bullet_->body.get();
  const int n = static_cast<int>(x_.rows());
  // Held nodes: Bullet integrates x += v·dt for mass-0 nodes too, and its links leave
  // them alone.
  for (size_t k = 0; k < grippers_.size(); ++k) {
    const Gripper& g = grippers_[k];
    for (size_t j = 0; j < g.held.size(); ++j) {
      const Vec3 p = pose1[k] * Vec3(g.local.row(j).transpose());
      const int i = g.held[j];
      sb->m_nodes[i].m_v = Bt((p.x() - x_(i, 0)) / dt, (p.y() - x_(i, 1)) / dt, (p.z() - x_(i, 2)) / dt);
    }
  }
  const double h = dt / m.substeps;
  for (int s = 0; s < m.substeps; ++s) {
    if (!m.bending.hinges.empty()) AddHingeForces();
    const double t0 = ClockSeconds();
    bullet_->world.stepSimulation(btScalar(h), 0, btScalar(h));
    timings_.bullet_seconds += ClockSeconds() - t0;
  }
  x1.resize(n, 3);
  for (int i = 0; i < n; ++i) {
    const btVector3& p = sb->m_nodes[i].m_x;
    x1.row(i) << p.x(), p.y(), p.z();
  }
  if (vb) {
    vb->resize(n, 3);
    for (int i = 0; i < n; ++i) {
      const btVector3& u = sb->m_nodes[i].m_v;
      vb->row(i) << u.x(), u.y(), u.z();
    }
  }
  for (size_t k = 0; k < grippers_.size(); ++k) {
    const Gripper& g = grippers_[k];
    for (size_t j = 0; j < g.held.size(); ++j)
      x1.row(g.held[j]) = (pose1[k] * Vec3(g.local.row(j).transpose())).transpose();
  }
}

CollisionReport ClothWorld::Step() {
  const double t_step = ClockSeconds();
  const double own0 = timings_.bullet_seconds + timings_.bending_seconds;
  const ClothModel& m = *model_;
  const double dt = m.options.time_step;
  const double t1 = time_ + dt;
  const int n = static_cast<int>(x_.rows());
  const int substeps = m.substeps;
  std::vector<Eigen::Isometry3d> pose1(grippers_.size());
  for (size_t k = 0; k < grippers_.size(); ++k) pose1[k] = PoseAt(grippers_[k], t1);
  // With sub-steps the velocity at the step's end is Bullet's, not the mean over the
  // step ((x1 − x0)/dt): a mode fast enough to need sub-steps turns within one step, and
  // taking its mean velocity as the new one pumped energy into a curling strip.
  Points3 x1, vb;
  StepBullet(pose1, x1, substeps > 1 ? &vb : nullptr);
  const Points3 xb = substeps > 1 ? x1 : Points3();
  CollisionReport rep;
  if (handler_) {
    Eigen::VectorXd im(n);
    for (int i = 0; i < n; ++i) im[i] = holder_[i] >= 0 ? 0.0 : 1 / m.mass[i];
    // With sub-steps, friction also never reverses the velocity Bullet ends the step with.
    Points3 from;
    if (substeps > 1) {
      from = xb - vb * dt;
      for (int i = 0; i < n; ++i)
        if (holder_[i] >= 0) from.row(i) = x_.row(i);
    }
    rep = handler_->Apply(x_, x1, im, dt, colliders_, substeps > 1 ? &from : nullptr);
    AddCollisionTimings(rep);
    timings_.ccd_collisions += rep.ccd_collisions;
    timings_.fail_safe_steps += rep.fail_safe_used;
    timings_.reverted_steps += rep.reverted;
    timings_.remaining_collisions += rep.remaining_collisions;
    timings_.strain_violation_steps += rep.strain_violations > 0;
    timings_.max_strain = std::max(timings_.max_strain, rep.max_strain);
  }
  if (substeps > 1)
    v_ = (vb + (x1 - xb) / dt) * (1 - kdp_);  // Bullet's velocity and the handler's correction
  else
    v_ = (x1 - x_) * ((1 - kdp_) / dt);
  for (int i = 0; i < n; ++i)
    if (holder_[i] >= 0) v_.row(i) = (x1.row(i) - x_.row(i)) / dt;
  x_ = std::move(x1);
  time_ = t1;
  if (m.bending.plastic()) {
    const double tb = ClockSeconds();
    UpdatePlasticity(m.bending, bend_, x_);
    timings_.bending_seconds += ClockSeconds() - tb;
  }
  for (size_t k = 0; k < grippers_.size(); ++k) grippers_[k].pose = pose1[k];
  ++timings_.steps;
  SyncBullet();
  const double step_seconds = ClockSeconds() - t_step;
  step_total_seconds_ += step_seconds;
  const double parts = timings_.bullet_seconds + timings_.bending_seconds - own0 + rep.total_seconds;
  timings_.step_seconds += step_seconds - parts;
  return rep;
}

void ClothWorld::AddHingeForces() {
  const double t0 = ClockSeconds();
  btSoftBody* sb = bullet_->body.get();
  const int n = static_cast<int>(x_.rows());
  Points3 x(n, 3);
  for (int i = 0; i < n; ++i) {
    const btVector3& p = sb->m_nodes[i].m_x;
    x.row(i) << p.x(), p.y(), p.z();
  }
  force_.setZero(n, 3);
  AddBendingForces(model_->bending, bend_, x, force_);
  for (int i = 0; i < n; ++i)
    if (holder_[i] < 0) sb->addForce(Bt(force_(i, 0), force_(i, 1), force_(i, 2)), i);
  timings_.bending_seconds += ClockSeconds() - t0;
}

double ClothWorld::KineticEnergy() const {
  double ke = 0;
  for (int i = 0; i < x_.rows(); ++i)
    if (holder_[i] < 0) ke += 0.5 * model_->mass[i] * v_.row(i).squaredNorm();
  return ke;
}

std::string ClothWorld::Health() const {
  if (!x_.allFinite() || !v_.allFinite()) return "NaN in the simulation state";
  double vmax = 0;
  for (int i = 0; i < v_.rows(); ++i)
    if (holder_[i] < 0) vmax = std::max(vmax, v_.row(i).norm());
  if (vmax > model_->options.max_speed) return "blew up: node speed " + FormatFixed(vmax, 1) + " m/s";
  // (Standard gravity when the world has none: a weightless cloth may still move.)
  const double g = std::max(model_->options.gravity.norm(), 9.81);
  const double cap = 50 * model_->total_mass * g * std::max(model_->extent, 0.1);
  const double ke = KineticEnergy();
  if (ke > cap) return "blew up: kinetic energy " + FormatNumber(ke) + " J";
  return "";
}

ClothState ClothWorld::State() const { return ClothState{x_, v_, time_, bend_}; }

void ClothWorld::SetState(const ClothState& s) {
  if (s.x.rows() != x_.rows() || s.v.rows() != x_.rows() || !std::isfinite(s.time))
    throw Error("cloth world: SetState needs #V×3 positions and velocities of this model");
  if (s.bending.rest_angle.size() != bend_.rest_angle.size() || s.bending.plastic.rows() != bend_.plastic.rows())
    throw Error("cloth world: SetState needs the bending state of this model");
  x_ = s.x;
  v_ = s.v;
  time_ = s.time;
  bend_ = s.bending;
  for (auto& g : grippers_) g.pose = PoseAt(g, time_);
  SyncBullet();
}

void ClothWorld::SetStrainZones(bool on) {
  if (handler_) handler_->SetStrainZones(on);
}

SettleReport ClothWorld::Settle(const SettleOptions& o) {
  const double t_settle = ClockSeconds(), stepping = step_total_seconds_;
  o.Validate();
  const double dt = model_->options.time_step;
  const int window = std::max(4, static_cast<int>(std::lround(o.window / dt)));
  const int quarter = std::max(1, window / 4);
  const int max_steps = static_cast<int>(std::ceil(o.time_cap / dt));
  const int min_steps = static_cast<int>(std::ceil(o.min_time / dt));
  SettleReport r;
  // Snapshots every quarter window; settled when now vs 4 snapshots ago moved < distance.
  std::vector<Points3> ring;
  int step = 0;
  bool capped = false;
  for (step = 1; step <= max_steps; ++step) {
    const CollisionReport c = Step();
    r.fail_safe_steps += c.fail_safe_used;
    r.zone_rounds += c.zone_iterations;
    r.ccd_tests += c.ccd_tests;
    capped = o.ccd_test_cap > 0 && r.ccd_tests >= o.ccd_test_cap;
    if (step % quarter && !capped) continue;
    const std::string bad = Health();
    if (!bad.empty()) {
      r.failure = bad;
      break;
    }
    if (capped && step % quarter) break;  // the ring keeps snapshots a quarter window apart
    ring.push_back(x_);
    if (ring.size() > 5) ring.erase(ring.begin());
    if (ring.size() == 5) {
      r.motion = (ring.back() - ring.front()).rowwise().norm().maxCoeff();
      if (step >= min_steps && r.motion < o.distance) {
        r.settled = true;
        break;
      }
    }
    if (capped) break;
  }
  r.steps = std::min(step, max_steps);
  r.sim_time = r.steps * dt;
  r.kinetic_energy = KineticEnergy();
  for (int i = 0; i < v_.rows(); ++i)
    if (holder_[i] < 0) r.max_speed = std::max(r.max_speed, v_.row(i).norm());
  if (r.failure.empty() && !r.settled) {
    r.timed_out = true;
    const std::string moving = " (still moving " + FormatNumber(r.motion) + " m per settle window)";
    r.failure = capped ? "not settled when its " + std::to_string(o.ccd_test_cap) +
                             " pair CCD tests were spent, after " + FormatNumber(r.steps * dt) + " s" + moving
                       : "not settled within time_cap " + FormatNumber(o.time_cap) + " s" + moving;
  }
  timings_.settle_seconds += ClockSeconds() - t_settle - (step_total_seconds_ - stepping);
  return r;
}

}  // namespace drape
