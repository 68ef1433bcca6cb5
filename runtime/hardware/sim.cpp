// SimWorld: the quasi-static cloth state, two simulated arms, the Kinect, IR sensors and
// the table (see sim.h).
#include "runtime/hardware/sim.h"

#include <cmath>
#include <limits>
#include <queue>

#include "common/error.h"
#include "common/field_error.h"
#include "common/format.h"
#include "common/rng.h"
#include "common/timing.h"
#include "generator/cloth/measure.h"
#include "generator/cloth/world.h"

namespace drape::hardware {

namespace {

Eigen::Matrix3d Yaw(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }

// Gripper frame columns: closing, approach × closing, approach.
Eigen::Matrix3d GripperAxes(const GripperPose& p) {
  Eigen::Matrix3d R;
  const Vec3 a = p.approach.normalized(), c = p.closing.normalized();
  R.col(0) = c;
  R.col(1) = a.cross(c);
  R.col(2) = a;
  return R;
}

// Whether a point `q` in the jaw frame lies in the jaw box of half-extents `half`.
bool InJaws(const Vec3& q, const Vec3& half) { return (q.cwiseAbs().array() <= half.array()).all(); }

// A pinch: a point of the garment's pattern, on face `face` at barycentric `bary`.
struct Pinch {
  int face = -1;
  Vec3 bary = Vec3::Zero();
  int vertex = -1;           // the face's vertex nearest the pinch (Hang's anchor vertex)
  Vec3 rest = Vec3::Zero();  // the point on the flat garment (m)
  // What the jaws hold of the mesh: its nodes inside the jaw box, and of every face with
  // a sample inside it the vertex nearest the jaw centre (a coarse mesh may have no
  // node between the jaws). The let-go fall and the placing hold exactly these.
  std::vector<int> nodes;
};

}  // namespace

const char* GraspOutcomeName(GraspOutcome o) {
  switch (o) {
    case GraspOutcome::kMiss:
      return "miss";
    case GraspOutcome::kOneLayer:
      return "one_layer";
    case GraspOutcome::kBothLayers:
      return "both_layers";
    case GraspOutcome::kLost:
      return "lost";
  }
  return "?";
}

const char* ClothStateName(ClothState s) {
  switch (s) {
    case ClothState::kOnTable:
      return "on_table";
    case ClothState::kHanging:
      return "hanging";
    case ClothState::kHeldByTwo:
      return "held_by_two";
    case ClothState::kLost:
      return "lost";
  }
  return "?";
}

void CaptureOptions::Validate() const {
  if (frames < 1 || frames > 100000) BadField(frames, "CaptureOptions.frames", "must be in 1..100000");
  if (!(degrees > 0 && degrees <= 3600)) BadField(degrees, "CaptureOptions.degrees", "must be in (0, 3600]");
}

Path StraightPath(const GripperPose& from, const GripperPose& to, double speed, int steps) {
  if (!(speed > 0)) throw Error("path: speed must be > 0 m/s");
  if (steps < 1) throw Error("path: steps must be >= 1");
  const double T = (to.position - from.position).norm() / speed;
  Path p;
  for (int i = 0; i <= steps; ++i) {
    const double s = double(i) / steps;
    GripperPose q = to;
    q.position = (1 - s) * from.position + s * to.position;
    p.push_back({s * T, q});
  }
  return p;
}

void SimOptions::Validate() const {
  hang.Validate();
  if (!(jaw_opening > 0 && jaw_opening < 0.5)) throw Error("sim.jaw_opening: must be in (0, 0.5) m");
  if (!(finger_depth > 0 && finger_depth < 0.5)) throw Error("sim.finger_depth: must be in (0, 0.5) m");
  if (!(finger_width > 0 && finger_width < 0.5)) throw Error("sim.finger_width: must be in (0, 0.5) m");
  if (!(speed > 0)) throw Error("sim.speed: must be > 0 m/s");
  if (!(drag_coefficient >= 0 && drag_coefficient <= 10)) throw Error("sim.drag_coefficient: must be in [0, 10]");
  if (!(strain_lead_weight >= 0 && strain_lead_weight <= 1)) throw Error("sim.strain_lead_weight: must be in [0, 1]");
  if (fall_ccd_test_cap < 0) throw Error("sim.fall_ccd_test_cap: must be >= 0 (0: no cap)");
  camera.Validate();
  ir.Validate();
  if (!ir_mount.allFinite()) throw Error("sim.ir_mount: must be finite");
  if (table.isEmpty()) throw Error("sim.table: empty box");
}

namespace {

class SimArm final : public Arm {
 public:
  SimArm(SimWorld::Impl* w, int k) : w_(w), k_(k) {}
  std::string name() const override { return k_ == 0 ? "left" : "right"; }
  GripperPose pose() const override;
  double Move(const Path& path) override;
  GraspReport Close() override;
  void Open() override;
  bool HoldsCloth() const override;
  double jaw_opening() const override;

 private:
  SimWorld::Impl* w_;
  int k_;
};

class SimCamera final : public DepthCamera {
 public:
  explicit SimCamera(SimWorld::Impl* w) : w_(w) {}
  Sweep CaptureTurning(Arm& holder, const CaptureOptions& options, uint64_t seed) override;

 private:
  SimWorld::Impl* w_;
};

class SimIr final : public RangeSensor {
 public:
  SimIr(SimWorld::Impl* w, int k) : w_(w), k_(k) {}
  double Read() override;
  Vec3 mount() const override;
  double max_range() const override;

 private:
  SimWorld::Impl* w_;
  int k_;
};

class SimTable final : public Table {
 public:
  explicit SimTable(const Eigen::AlignedBox3d& b) : box_(b) {}
  Eigen::AlignedBox3d top() const override { return box_; }

 private:
  Eigen::AlignedBox3d box_;
};

}  // namespace

struct SimWorld::Impl {
  struct ArmState {
    GripperPose pose;
    bool closed = false;
    bool holds = false;
    Pinch pinch;
  };
  Garment garment;
  Material material;
  MaterialFit fit;
  SimOptions o;
  uint64_t seed = 0;
  TriMesh mesh;  // world frame
  ClothState state = ClothState::kOnTable;
  int hang_from = -1;
  ArmState arms[2];
  int hangs = 0;
  int fallbacks = 0;  // let-go falls that re-hung from the flat garment (no node between the pads)
  int unsettled = 0;  // let-go falls stopped by the time or CCD test cap still moving (kept)
  int retries = 0;    // falls and placings run again at half the time step after blowing up
  SimWorld::FallCost fall_cost;
  double sim_seconds = 0, sense_seconds = 0;
  uint64_t version = 0, ir_version = ~uint64_t(0);
  std::unique_ptr<SweepScene> ir_scene;
  SweepOptions ir_scene_options;
  Rng ir_rng[2] = {Rng(0), Rng(0)};
  std::unique_ptr<SimArm> arm_objs[2];
  std::unique_ptr<SimIr> ir_objs[2];
  std::unique_ptr<SimCamera> camera;
  std::unique_ptr<SimTable> table;

  int ArmIndex(const Arm& a) const {
    for (int k = 0; k < 2; ++k)
      if (arm_objs[k].get() == &a) return k;
    throw Error("sim: the arm does not belong to this world");
  }

  // The garment hangs from arm k's pinch until stationary (the cloth core: Bullet + collision handling, settled).
  void Rehang(int k) {
    const ArmState& a = arms[k];
    const Vec3 offset = a.pinch.rest - garment.mesh.V.row(a.pinch.vertex).transpose();
    const auto t0 = Clock::now();
    const HangResult r = Hang(garment, a.pinch.vertex, Vec3(offset.x(), offset.y(), 0), material, fit, o.hang,
                              DeriveSeed(seed, "hang/" + std::to_string(hangs)));
    sim_seconds += Since(t0);
    ++hangs;
    if (!r.ok)
      throw NumericalError("cloth simulation: hanging from the " + std::string(k ? "right" : "left") +
                           " gripper did not come to rest (" + r.failure + ")");
    const Eigen::Matrix3d R = Yaw(a.pose.wrist);
    mesh.F = r.mesh.F;
    mesh.V.resize(r.mesh.NumVertices(), 3);
    for (int i = 0; i < r.mesh.NumVertices(); ++i)
      mesh.V.row(i) = (R * r.mesh.V.row(i).transpose() + a.pose.position).transpose();
    arms[k].pinch.nodes = {arms[k].pinch.vertex};  // what the hang held
    state = ClothState::kHanging;
    hang_from = k;
    ++version;
  }

  // What jaws at `pose` would close on (const: nothing changes). Face samples
  // (barycentric step 1/8) in the jaw box; the pinch is the sample nearest the jaw centre.
  struct Capture {
    GraspReport report;
    Pinch pinch;
    Vec3 centroid = Vec3::Zero();  // mean of the face samples in the jaw box (world)
  };
  Capture CaptureAt(const GripperPose& pose) const {
    Capture out;
    GraspReport& rep = out.report;
    rep.point = pose.position;
    if (state == ClothState::kLost) {
      rep.note = "the garment is lost (on the floor)";
      return out;
    }
    const Eigen::Matrix3d Rt = GripperAxes(pose).transpose();
    const Vec3 half(o.jaw_opening / 2, o.finger_width / 2, o.finger_depth / 2);
    const int n = 8;
    double best = std::numeric_limits<double>::infinity();
    bool front = false, back = false;
    const bool layered = int(garment.layer.size()) == garment.mesh.NumVertices();
    Pinch& pin = out.pinch;
    int samples = 0;
    std::vector<int> faces;  // captured
    for (int f = 0; f < mesh.NumFaces(); ++f) {
      const Vec3 A = mesh.V.row(mesh.F(f, 0)), B = mesh.V.row(mesh.F(f, 1)), C = mesh.V.row(mesh.F(f, 2));
      bool hit = false;
      for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
          const Vec3 bary(double(n - i - j) / n, double(i) / n, double(j) / n);
          const Vec3 p = bary[0] * A + bary[1] * B + bary[2] * C;
          const Vec3 q = Rt * (p - pose.position);
          if (!InJaws(q, half)) continue;
          hit = true;
          out.centroid += p;
          ++samples;
          const double d = q.squaredNorm();
          if (d < best) {
            best = d;
            pin.face = f;
            pin.bary = bary;
          }
        }
      if (!hit) continue;
      ++rep.captured;
      faces.push_back(f);
      bool is_back = false;
      if (layered)
        for (int c = 0; c < 3; ++c) is_back |= garment.layer[mesh.F(f, c)] == 1;
      (is_back ? back : front) = true;
    }
    if (rep.captured == 0) {
      rep.note = "no cloth between the jaws";
      return out;
    }
    out.centroid /= samples;
    int m = 0;
    for (int c = 1; c < 3; ++c)
      if (pin.bary[c] > pin.bary[m]) m = c;
    pin.vertex = mesh.F(pin.face, m);
    pin.nodes = JawNodes(faces, Rt, pose.position, half);
    pin.rest = Vec3::Zero();
    for (int c = 0; c < 3; ++c) pin.rest += pin.bary[c] * garment.mesh.V.row(mesh.F(pin.face, c)).transpose();
    rep.outcome = front && back ? GraspOutcome::kBothLayers : GraspOutcome::kOneLayer;
    rep.note = std::to_string(rep.captured) + " faces between the jaws";
    return out;
  }

  // Pinch::nodes of jaws at `centre` with axes Rt (rows) and half-extents `half`.
  std::vector<int> JawNodes(const std::vector<int>& faces, const Eigen::Matrix3d& Rt, const Vec3& centre,
                            const Vec3& half) const {
    std::vector<int> out;
    for (int i = 0; i < mesh.NumVertices(); ++i) {
      if (InJaws(Rt * (mesh.V.row(i).transpose() - centre), half)) out.push_back(i);
    }
    for (int f : faces) {
      int best = mesh.F(f, 0);
      for (int c = 1; c < 3; ++c)
        if ((mesh.V.row(mesh.F(f, c)).transpose() - centre).squaredNorm() <
            (mesh.V.row(best).transpose() - centre).squaredNorm())
          best = mesh.F(f, c);
      out.push_back(best);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  // Pattern point (uv, m) of a pinch.
  Vec2 PinchUv(const Pinch& p) const {
    const Garment& g = garment;
    if (g.uv.rows() != g.mesh.NumVertices()) return Vec2(p.rest.x(), p.rest.y());
    Vec2 uv = Vec2::Zero();
    for (int c = 0; c < 3; ++c) uv += p.bary[c] * g.uv.row(g.mesh.F(p.face, c)).transpose();
    return uv;
  }

  // Cloth inside arm k's jaws: it now holds what CaptureAt finds there.
  GraspReport PinchAt(int k) {
    ArmState& a = arms[k];
    Capture c = CaptureAt(a.pose);
    if (c.report.captured == 0) return c.report;
    a.pinch = c.pinch;
    a.holds = true;
    return c.report;
  }
};

GripperPose SimArm::pose() const { return w_->arms[k_].pose; }
double SimArm::jaw_opening() const { return w_->o.jaw_opening; }
bool SimArm::HoldsCloth() const { return w_->arms[k_].holds && w_->state != ClothState::kLost; }

double SimArm::Move(const Path& path) {
  if (path.empty()) return 0;
  auto& a = w_->arms[k_];
  const GripperPose before = a.pose;
  a.pose = path.back().pose;
  if (!a.holds) return path.back().time;
  if (w_->state == ClothState::kOnTable) {
    if (w_->arms[1 - k_].holds)
      throw Error("sim: lifting a garment from the table with both grippers is not simulated");
    w_->Rehang(k_);  // picked up: it hangs from this gripper
  } else if (w_->state == ClothState::kHanging && w_->hang_from == k_) {
    const Eigen::Matrix3d R = Yaw(a.pose.wrist - before.wrist);
    for (int i = 0; i < w_->mesh.NumVertices(); ++i)
      w_->mesh.V.row(i) = (R * (w_->mesh.V.row(i).transpose() - before.position) + a.pose.position).transpose();
    ++w_->version;
  }
  return path.back().time;
}

GraspReport SimArm::Close() {
  auto& a = w_->arms[k_];
  if (a.closed) throw Error("sim: the " + name() + " gripper is already closed");
  a.closed = true;
  GraspReport r = w_->PinchAt(k_);
  if (a.holds && w_->state == ClothState::kHanging && w_->hang_from != k_) w_->state = ClothState::kHeldByTwo;
  return r;
}

namespace {
void FallFrom(SimWorld::Impl& w, int let_go);
}  // namespace

void SimArm::Open() {
  auto& a = w_->arms[k_];
  const bool held = a.holds;
  a.closed = false;
  a.holds = false;
  if (!held) return;
  if (w_->state == ClothState::kHeldByTwo) {
    FallFrom(*w_, k_);
  } else if (w_->state == ClothState::kHanging) {
    w_->state = ClothState::kLost;  // dropped
    ++w_->version;
  }
}

Sweep SimCamera::CaptureTurning(Arm& holder, const CaptureOptions& options, uint64_t seed) {
  options.Validate();
  SimWorld::Impl& w = *w_;
  const int k = w.ArmIndex(holder);
  if (w.state != ClothState::kHanging || w.hang_from != k)
    throw Error("camera: the garment must hang from the " + holder.name() + " gripper alone to turn it");
  const GripperPose& p = w.arms[k].pose;
  if (std::hypot(p.position.x(), p.position.z()) > 1e-9)
    throw Error("camera: move the holding gripper to the sensing pose (0, y, 0) first");
  const auto t0 = Clock::now();
  // Object frame: the jaws at the origin, turned with the wrist.
  const Eigen::Matrix3d Rt = Yaw(p.wrist).transpose();
  TriMesh obj;
  obj.F = w.mesh.F;
  obj.V.resize(w.mesh.NumVertices(), 3);
  for (int i = 0; i < w.mesh.NumVertices(); ++i)
    obj.V.row(i) = (Rt * (w.mesh.V.row(i).transpose() - p.position)).transpose();
  SweepOptions so = w.o.camera;
  so.frames = options.frames;
  so.degrees = options.degrees;
  so.back_and_forth = options.back_and_forth;
  so.gripper_height = p.position.y();
  Sweep s = SimulateSweep(obj, so, seed);
  w.sense_seconds += Since(t0);
  return s;
}

Vec3 SimIr::mount() const { return w_->o.ir_mount; }
double SimIr::max_range() const { return w_->o.ir.max_range; }

double SimIr::Read() {
  SimWorld::Impl& w = *w_;
  if (w.state == ClothState::kLost || w.mesh.NumFaces() == 0) return std::numeric_limits<double>::infinity();
  const auto t0 = Clock::now();
  if (w.ir_version != w.version) {
    // The scene's object frame is the world shifted down by 1 m (its gripper height).
    TriMesh m = w.mesh;
    m.V.col(1).array() -= 1.0;
    w.ir_scene_options = SweepOptions{};
    w.ir_scene_options.scene = false;
    w.ir_scene_options.gripper_height = 1.0;
    w.ir_scene_options.kinect.noise = false;
    w.ir_scene = std::make_unique<SweepScene>(m, w.ir_scene_options);
    w.ir_version = w.version;
  }
  const GripperPose& p = w.arms[k_].pose;
  const Vec3 origin = p.position + GripperAxes(p) * w.o.ir_mount;
  const double r = w.ir_scene->RangeAlongRay(origin, p.approach.normalized(), 0.0, w.o.ir, &w.ir_rng[k_]);
  w.sense_seconds += Since(t0);
  return r;
}

void PlaceFlatOptions::Validate() const {
  if (!(spread > 0 && spread <= 1.2)) BadField(spread, "PlaceFlatOptions.spread", "must be in (0, 1.2]");
  if (!(lift_time > 0)) BadField(lift_time, "PlaceFlatOptions.lift_time", "must be > 0 s");
  if (!(lay_time > 0)) BadField(lay_time, "PlaceFlatOptions.lay_time", "must be > 0 s");
  if (!(settle_cap > 0)) BadField(settle_cap, "PlaceFlatOptions.settle_cap", "must be > 0 s");
  if (!(min_pad > 0 && min_pad < 0.5)) BadField(min_pad, "PlaceFlatOptions.min_pad", "must be in (0, 0.5) m");
}

namespace {
// Cloth-world gripper frame (generator/cloth Jaw: x = closing, y = towards the wrist).
Eigen::Isometry3d JawFrame(const GripperPose& p) {
  const Vec3 x = p.closing.normalized(), y = -p.approach.normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = x.cross(y);
  T.translation() = p.position;
  return T;
}

// The cloth-world jaw of a fall's or a placing's gripper: it holds its pinch's nodes
// (Pinch::nodes), and these pads (1.5 mean edges at least) give the reach of the held
// patch below the gripper (HangBound).
Jaw PlaceJaw(const SimWorld::Impl& w, const PlaceFlatOptions& po) {
  double edge = 0;
  const auto edges = UniqueEdges(w.garment.mesh);
  for (const auto& e : edges) edge += (w.garment.mesh.V.row(e[0]) - w.garment.mesh.V.row(e[1])).norm();
  edge /= std::max<size_t>(1, edges.size());
  Jaw jaw;
  jaw.opening = w.o.jaw_opening;
  jaw.pad_length = std::max({po.min_pad, w.o.finger_depth, 1.5 * edge});
  jaw.pad_width = std::max({po.min_pad, w.o.finger_width, 1.5 * edge});
  return jaw;
}

// The garment's cloth model with the hang's parameters (generator/hang: the fitted
// stiffness, the material's bending and its layers' friction on each other, the strain
// limit and layer thickness of the release's simulation settings), rest lengths from the
// flat pattern.
// `dt` is the release's time step, or half of it for a retry (damping per second kept).
// Strain handling and air drag as SimOptions says for falls and placings.
std::shared_ptr<const ClothModel> ClothModelOf(const SimWorld::Impl& w, double dt) {
  HangOptions o = w.o.hang;
  o.strain_monotone = w.o.strain_monotone;
  o.drag_coefficient = w.o.drag_coefficient;
  ClothOptions co = HangClothOptions(w.material, o, dt);
  co.collision.strain_lead_weight = w.o.strain_lead_weight;
  return MakeClothModel(w.garment.mesh, w.garment.layer, ClothMaterialFor(w.material, w.fit, o), co);
}

// Both grippers hold the garment and arm `let_go` opens: the cloth core runs from the
// garment as the two grippers held it, the other gripper keeping the nodes its jaws
// pinched (Pinch::nodes), until it comes to rest below that gripper (the hang's settling
// criterion and time cap). A gripper that holds no node (none left to pinch) falls back
// to a hang from the flat garment at the pinched point. A fall that blows up is run once
// more at half the time step (damping per second kept), as a hang is; throws
// NumericalError if that blows up too.
void FallFrom(SimWorld::Impl& w, int let_go) {
  const int keep = 1 - let_go;
  const auto t0 = Clock::now();
  SettleOptions so;
  so.distance = w.o.hang.settle_distance;
  so.window = w.o.hang.settle_window;
  so.min_time = w.o.hang.min_time;
  so.time_cap = w.o.hang.time_cap;
  so.ccd_test_cap = w.o.fall_ccd_test_cap;
  double dt = w.o.hang.time_step;
  const std::string side = keep ? "right" : "left";
  SettleReport sr;
  Points3 x;
  std::string verdict;
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (attempt > 0) dt /= 2, ++w.retries;
    ClothWorld cw(ClothModelOf(w, dt), w.mesh.V);
    const int g = cw.AddGripper(PlaceJaw(w, PlaceFlatOptions{}), JawFrame(w.arms[keep].pose));
    if (cw.Hold(g, w.arms[keep].pinch.nodes).nodes == 0) {
      w.sim_seconds += Since(t0);
      ++w.fallbacks;
      w.Rehang(keep);
      return;
    }
    sr = cw.Settle(so);
    x = cw.positions();
    SimWorld::FallCost& c = w.fall_cost;
    ++c.falls, c.steps += sr.steps, c.fail_safe_steps += sr.fail_safe_steps, c.zone_rounds += sr.zone_rounds;
    c.ccd_tests += sr.ccd_tests, c.max_ccd_tests = std::max(c.max_ccd_tests, sr.ccd_tests);
    if (!sr.settled && !sr.timed_out) continue;
    // The database hang's verdict on where it came to rest (CGAL's exact test, strain bounds).
    TriMesh fallen;
    fallen.V = x;
    fallen.F = w.garment.mesh.F;
    verdict = MeasurementVerdict(MeasureCloth(fallen, w.garment.mesh.V), w.material, w.o.hang, "the garment");
    if (verdict.empty()) break;
    verdict = "fallen to hang from the " + side + " gripper: " + verdict;
  }
  w.sim_seconds += Since(t0);
  ++w.hangs;
  const std::string retried = "; after a retry at time_step " + FormatNumber(dt) + " s";
  if (!sr.settled && !sr.timed_out)
    throw NumericalError("cloth simulation: the garment falling to hang from the " + side + " gripper blew up (" +
                         sr.failure + retried + ")");
  if (!verdict.empty()) throw NumericalError("cloth simulation: " + verdict + " (" + retried.substr(2) + ")");
  w.unsettled += sr.timed_out;
  w.mesh.V = x;
  w.state = ClothState::kHanging;
  w.hang_from = keep;
  ++w.version;
}

// m: the lowest held node is lowered no closer than this to the table top (a few layer
// thicknesses: the cloth already lying there passes beneath it).
constexpr double kPlaceClearance = 0.01;
// m: the garment is first moved back at least this far from the table's near side.
constexpr double kPlaceBack = 0.1;

// m: how far below its grippers the garment can hang once they hold it level, whatever
// shape it has now: every node hangs from a held node by a path of mesh edges, each at
// most (1 + the strain limit) × its rest length, so no node is further below the lowest
// held node than its rest-length path distance (Dijkstra over the pattern's edges, from
// the held nodes of both grippers) times that; plus the reach of the pads below the
// gripper (the jaw box's half-diagonal).
double HangBound(const ClothWorld& cw, const SimWorld::Impl& w, const Jaw& jaw, const int g[2]) {
  const TriMesh& rest = w.garment.mesh;
  const int n = rest.NumVertices();
  std::vector<std::vector<std::pair<int, double>>> adj(n);
  for (const auto& e : UniqueEdges(rest)) {
    const double l = (rest.V.row(e[0]) - rest.V.row(e[1])).norm();
    adj[e[0]].push_back({e[1], l});
    adj[e[1]].push_back({e[0], l});
  }
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  for (int k = 0; k < 2; ++k)
    for (int i : cw.HeldNodes(g[k])) dist[i] = 0, queue.push({0.0, i});
  while (!queue.empty()) {
    const auto [d, i] = queue.top();
    queue.pop();
    if (d > dist[i]) continue;
    for (const auto& [j, l] : adj[i])
      if (d + l < dist[j]) dist[j] = d + l, queue.push({d + l, j});
  }
  double far = 0;
  for (double d : dist)
    if (std::isfinite(d)) far = std::max(far, d);
  const double reach = 0.5 * Vec3(jaw.opening, jaw.pad_length, jaw.pad_width).norm();
  return far * (1 + cw.model().material.max_strain) + reach;
}

// The grippers' paths (g: their ids in cw): back from the table, up until the garment
// hanging from them level would clear its top (HangBound) and apart, across to above the
// near edge of the table, then lower while carrying across it. Returns the time (s) at
// which both paths end.
double SetPlacePaths(ClothWorld& cw, const SimWorld::Impl& w, const PlaceFlatOptions& po, const Jaw& jaw,
                     const int g[2]) {
  const double hang = HangBound(cw, w, jaw, g);
  const Vec3 a = w.arms[0].pose.position, b = w.arms[1].pose.position;
  const Vec2 ua = w.arms[0].pinch.rest.head<2>();
  const Vec2 ub = w.arms[1].pinch.rest.head<2>();
  const double d = std::max(0.05, po.spread * (ua - ub).norm());
  const double top = w.o.table.max().y();
  const double z0 = w.o.table.min().z() + 0.05, x0 = w.o.table.center().x();
  const double z1 = std::min(w.o.table.max().z() - 0.05, z0 + hang);
  const double sx = b.x() >= a.x() ? 1 : -1;  // keep the arms' left/right order along x
  auto key = [&](int k, const Vec3& c) {
    GripperPose p = w.arms[k].pose;
    p.position = c + Vec3((k == 0 ? -0.5 : 0.5) * sx * d, 0, 0);
    return JawFrame(p);
  };
  // Lowered to 3 cm above the top, or higher when a held node would otherwise come
  // closer to it than kPlaceClearance: the pads of a coarse mesh reach further (1.5 mean
  // edges), and a held node carried down onto the cloth lying on the table pushes it
  // through itself (the cloth core moves neither a held node nor cloth pinned on a box).
  double y1 = top + 0.03;
  for (int k = 0; k < 2; ++k) {
    const Eigen::Isometry3d to_jaw = JawFrame(w.arms[k].pose).inverse();
    const Eigen::Isometry3d end = key(k, Vec3(x0, top + 0.03, z1));
    for (int i : cw.HeldNodes(g[k])) {
      const double low = (end * (to_jaw * Vec3(cw.positions().row(i).transpose()))).y();  // at top + 0.03
      y1 = std::max(y1, top + 0.03 + (top + kPlaceClearance - low));
    }
  }
  // First back from the table's near side (kPlaceBack clear of it), up until the garment
  // would clear the top and apart, then across (the grippers moving as one rigid body):
  // carried across while still hanging below the top, or lifted while touching the near
  // side, it was dragged over the table's near edge. Spreading while carried across gave
  // more crossings between cloth held by the two grippers (paper-release shorts, seed 1:
  // 3 of 10 placed, against 6 of 10 spread while lifted).
  const double high = top + hang + 0.05;
  const double back = std::min(0.0, w.o.table.min().z() - kPlaceBack - cw.positions().col(2).maxCoeff());
  const double T0 = cw.time(), T1 = T0 + po.lift_time, T2 = T1 + po.lift_time, T3 = T2 + po.lay_time;
  for (int k = 0; k < 2; ++k) {
    GripperPath path;
    path.times = {T0, T1, T2, T3};
    path.poses = {JawFrame(w.arms[k].pose), key(k, Vec3(x0, high, 0.5 * (a.z() + b.z()) + back)),
                  key(k, Vec3(x0, high, z0)), key(k, Vec3(x0, y1, z1))};
    cw.SetPath(g[k], path);
  }
  return T3;
}
}  // namespace

namespace {
// m: a node this far below the table top hangs off the table.
constexpr double kOffTable = 0.01;

// Why the garment as it lies may not be reported as placed ("" = it may): the verdict a
// database hang gets (hang.h MeasurementVerdict: CGAL's exact test, strain bounds), and
// every node on the table (not hanging off it over an edge).
std::string LyingFailure(const SimWorld::Impl& w, const Points3& x) {
  TriMesh lying;
  lying.V = x;
  lying.F = w.garment.mesh.F;
  const std::string v = MeasurementVerdict(MeasureCloth(lying, w.garment.mesh.V), w.material, w.o.hang, "the garment");
  if (!v.empty()) return "placed flat: " + v;
  // On the table, not hanging off it (nodes rest thickness/2 above the top).
  const double below = w.o.table.max().y() - x.col(1).minCoeff();
  if (below > kOffTable)
    return "placed flat: the garment hangs off the table (a node " + FormatNumber(below) + " m below its top)";
  return "";
}

// One attempt at placing flat at time step dt (see SimWorld::PlaceFlat); the cloth as it
// ended and the grippers' last positions go to x and ends.
PlaceFlatReport PlaceOnce(const SimWorld::Impl& w, const PlaceFlatOptions& po, double dt, Points3& x, Vec3 ends[2]) {
  PlaceFlatReport rep;
  ClothWorld cw(ClothModelOf(w, dt), w.mesh.V);
  BoxCollider table;
  table.pose.translation() = w.o.table.center();
  table.half_extents = w.o.table.sizes() / 2;
  // The fitted μ reproduces the measured friction angle in this simulation; tan(angle) if unfitted.
  table.friction = w.fit.friction > 0 ? w.fit.friction : w.material.FrictionCoefficient();
  cw.AddCollider(table);
  const Jaw jaw = PlaceJaw(w, po);
  int g[2];
  for (int k = 0; k < 2; ++k) {
    g[k] = cw.AddGripper(jaw, JawFrame(w.arms[k].pose));
    rep.held_nodes[k] = cw.Hold(g[k], w.arms[k].pinch.nodes).nodes;
  }
  if (rep.held_nodes[0] == 0 || rep.held_nodes[1] == 0) {
    rep.failure = "a gripper holds no cloth node in the cloth world";
    return rep;
  }
  // Back, up clear of the table and apart, across above its near edge, then lower while carrying across it.
  const double T2 = SetPlacePaths(cw, w, po, jaw, g);
  while (cw.time() < T2) {
    const CollisionReport cr = cw.Step();
    const std::string h = cw.Health();
    if (!h.empty()) {
      rep.failure = "cloth world: " + h;
      return rep;
    }
    // A held node carried into cloth pinned on the table forces a crossing the core can
    // only report (collision.h): from here on the cloth is no longer intersection-free.
    if (cr.remaining_collisions > 0) {
      rep.failure = "cloth world: a gripper pushed the cloth through itself at t = " + FormatNumber(cw.time()) +
                    " s (" + std::to_string(cr.remaining_collisions) + " crossings left)";
      return rep;
    }
  }
  for (int k = 0; k < 2; ++k) cw.Open(g[k]);
  SettleOptions so;
  so.min_time = 0.25;
  so.time_cap = po.settle_cap;
  so.distance = 0.005;
  const SettleReport sr = cw.Settle(so);
  rep.settled = sr.settled;
  if (!sr.failure.empty() && !sr.timed_out) rep.failure = "cloth world: " + sr.failure;
  rep.sim_time = cw.time();
  x = cw.positions();
  if (rep.failure.empty()) rep.failure = LyingFailure(w, x);
  for (int k = 0; k < 2; ++k) ends[k] = cw.GripperPose(g[k]).translation();
  rep.ok = rep.failure.empty();
  return rep;
}
}  // namespace

PlaceFlatReport SimWorld::PlaceFlat(const PlaceFlatOptions& po) {
  po.Validate();
  Impl& w = *impl_;
  if (w.state != ClothState::kHeldByTwo) throw Error("place flat: both grippers must hold the garment");
  const auto t0 = Clock::now();
  // A placing that blows up is run once more at half the time step, as a hang is.
  double dt = w.o.hang.time_step;
  Points3 x;
  Vec3 ends[2];
  PlaceFlatReport rep = PlaceOnce(w, po, dt, x, ends);
  if (!rep.ok && rep.held_nodes[0] > 0 && rep.held_nodes[1] > 0) {
    dt /= 2, ++w.retries;
    x.resize(0, 3);  // nothing of the first attempt's cloth is kept
    rep = PlaceOnce(w, po, dt, x, ends);
    if (!rep.ok) rep.failure += " (after a retry at time_step " + FormatNumber(dt) + " s)";
  }
  w.sim_seconds += Since(t0);
  if (x.rows() != w.mesh.V.rows()) return rep;  // failed before it was laid down: nothing changed
  w.mesh.V = x;
  for (int k = 0; k < 2; ++k) {
    w.arms[k].pose.position = ends[k];
    w.arms[k].closed = false;
    w.arms[k].holds = false;
  }
  w.state = ClothState::kOnTable;
  ++w.version;
  return rep;
}

SimWorld::SimWorld(Garment garment, Material material, MaterialFit fit, const SimOptions& options, uint64_t seed)
    : impl_(std::make_unique<Impl>()) {
  options.Validate();
  material.Validate();
  Impl& w = *impl_;
  if (garment.mesh.NumFaces() == 0) throw Error("sim: garment '" + garment.instance + "' has no mesh");
  w.garment = std::move(garment);
  w.material = std::move(material);
  w.fit = std::move(fit);
  w.o = options;
  w.seed = seed;
  // Flat on the table, front up: pattern (x, y, z) → world (x, z, −y), centred on the top.
  const TriMesh& g = w.garment.mesh;
  const Eigen::AlignedBox3d b = Bounds(g);
  const Vec3 c = b.center();
  const Vec3 top = w.o.table.center();
  w.mesh.F = g.F;
  w.mesh.V.resize(g.NumVertices(), 3);
  for (int i = 0; i < g.NumVertices(); ++i) {
    const Vec3 q = g.V.row(i).transpose() - c;
    w.mesh.V.row(i) =
        Vec3(top.x() + q.x(), w.o.table.max().y() + 0.001 + (g.V(i, 2) - b.min().z()), top.z() - q.y()).transpose();
  }
  for (int k = 0; k < 2; ++k) {
    w.arms[k].pose.position = Vec3(k == 0 ? 0.4 : -0.4, 1.3, 0.3);
    w.ir_rng[k] = Rng(DeriveSeed(seed, k == 0 ? "ir/left" : "ir/right"));
    w.arm_objs[k] = std::make_unique<SimArm>(&w, k);
    w.ir_objs[k] = std::make_unique<SimIr>(&w, k);
  }
  w.camera = std::make_unique<SimCamera>(&w);
  w.table = std::make_unique<SimTable>(w.o.table);
}

SimWorld::~SimWorld() = default;

Arm& SimWorld::arm(int i) {
  DRAPE_CHECK(i == 0 || i == 1, "arm index");
  return *impl_->arm_objs[i];
}
DepthCamera& SimWorld::camera() { return *impl_->camera; }
RangeSensor& SimWorld::ir(int i) {
  DRAPE_CHECK(i == 0 || i == 1, "arm index");
  return *impl_->ir_objs[i];
}
Table& SimWorld::table() { return *impl_->table; }
ClothState SimWorld::state() const { return impl_->state; }
const TriMesh& SimWorld::mesh() const { return impl_->mesh; }
const Garment& SimWorld::garment() const { return impl_->garment; }
int SimWorld::HeldVertex(int i) const { return impl_->arms[i].holds ? impl_->arms[i].pinch.vertex : -1; }
std::vector<int> SimWorld::HeldNodes(int i) const {
  return impl_->arms[i].holds ? impl_->arms[i].pinch.nodes : std::vector<int>{};
}
std::optional<Vec2> SimWorld::HeldUv(int i) const {
  const auto& a = impl_->arms[i];
  if (!a.holds) return std::nullopt;
  return impl_->PinchUv(a.pinch);
}

GraspProbe SimWorld::ProbeGrasp(const GripperPose& pose) const {
  const Impl::Capture c = impl_->CaptureAt(pose);
  GraspProbe p;
  p.report = c.report;
  if (c.report.captured == 0) return p;
  p.centroid = c.centroid;
  p.pinch = Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    p.pinch += c.pinch.bary[k] * impl_->mesh.V.row(impl_->mesh.F(c.pinch.face, k)).transpose();
  p.uv = impl_->PinchUv(c.pinch);
  return p;
}
const SimOptions& SimWorld::options() const { return impl_->o; }
int SimWorld::hangs() const { return impl_->hangs; }
int SimWorld::fallbacks() const { return impl_->fallbacks; }
int SimWorld::unsettled() const { return impl_->unsettled; }
int SimWorld::retries() const { return impl_->retries; }
const SimWorld::FallCost& SimWorld::fall_cost() const { return impl_->fall_cost; }
double SimWorld::simulation_seconds() const { return impl_->sim_seconds; }
double SimWorld::sensing_seconds() const { return impl_->sense_seconds; }

}  // namespace drape::hardware
