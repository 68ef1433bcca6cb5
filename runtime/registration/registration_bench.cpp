// registration_bench: (1) our rigid ICP (closest-point grid) vs Open3D's point-to-point
// ICP (Debian python3-open3d, run through open3d_icp.py) on the same pairs — speed and
// final error; (2) closest-point grid queries vs exact queries (Embree BVH, brute
// force); (3) the non-rigid step with the secant LM vs plain LM.
// A main that prints a table (run it on a quiet machine; times are wall-clock).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "common/rng.h"
#include "common/source_dir.h"
#include "common/timing.h"
#include "runtime/registration/registration.h"
#include "runtime/registration/test_meshes.h"

using namespace drape;
using namespace drape::registration;
namespace fs = std::filesystem;

namespace {

struct Pair {
  std::string name;
  TriMesh source, target;
  Similarity truth;  // source → target
};

Similarity Motion(double angle_deg, const Vec3& axis, const Vec3& t) {
  Similarity s;
  s.rotation = Eigen::AngleAxisd(angle_deg * M_PI / 180, axis.normalized()).toRotationMatrix();
  s.translation = t;
  return s;
}

// Target = a differently tessellated copy of the same surface, moved rigidly.
std::vector<Pair> MakePairs() {
  std::vector<Pair> p;
  {
    Pair a{"tube 1.2k→2.3k v, 15°", testing::FlatTube(40, 30, 0.5, 0.7, 0.08),
           testing::FlatTube(56, 41, 0.5, 0.7, 0.08), Motion(15, Vec3(0.2, 1, 0.3), Vec3(0.03, -0.02, 0.05))};
    p.push_back(a);
  }
  {
    Pair a{"wavy sheet 0.9k→3.6k v, 10°", testing::WavySheet(30, 30, 0.6, 0.5, 0.08),
           testing::WavySheet(60, 60, 0.6, 0.5, 0.08), Motion(10, Vec3(1, 0.5, 0.2), Vec3(0.02, 0.03, -0.02))};
    p.push_back(a);
  }
  {
    Pair a{"tube 4.8k→4.8k v, 25°", testing::FlatTube(80, 60, 0.5, 0.7, 0.08),
           testing::FlatTube(80, 60, 0.5, 0.7, 0.08), Motion(25, Vec3(0.1, 1, 0.1), Vec3(0.05, 0.0, 0.02))};
    p.push_back(a);
  }
  for (Pair& q : p) q.target.V = q.truth.Apply(q.target.V);
  return p;
}

void WriteXyz(const Points3& V, const fs::path& path) {
  std::ofstream f(path);
  f.precision(17);
  for (int i = 0; i < V.rows(); ++i) f << V(i, 0) << " " << V(i, 1) << " " << V(i, 2) << "\n";
}

bool HaveOpen3d() { return std::system("/usr/bin/python3 -c 'import open3d' >/dev/null 2>&1") == 0; }

// Vertex error against the true motion, and the paper's S→T surface error.
void Errors(const Pair& p, const Points3& moved, const ExactClosestPoint& tq, double* vertex_rms, double* s_to_t) {
  const Points3 want = p.truth.Apply(p.source.V);
  *vertex_rms = std::sqrt((moved - want).rowwise().squaredNorm().mean());
  *s_to_t = MeasureDirected(TriMesh{moved, p.source.F}, tq).mean;
}

void IcpComparison() {
  std::printf("\n== Rigid ICP: ours (closest-point grid, 64 cells) vs Open3D point-to-point ICP ==\n");
  const bool o3d = HaveOpen3d();
  if (!o3d)
    std::printf("(python3-open3d not found under /usr/bin/python3: `apt-get install -y python3-open3d` to compare)\n");
  const fs::path dir = fs::temp_directory_path() / "drape_registration_bench";
  fs::create_directories(dir);
  std::printf("%-30s %-22s %8s %8s %5s %12s %12s\n", "pair", "method", "build s", "icp s", "iter", "vertex RMS m",
              "S->T m");
  for (const Pair& p : MakePairs()) {
    const ExactClosestPoint tq(p.target);
    for (bool refined : {true, false}) {
      auto t0 = Clock::now();
      GridOptions go;
      const ClosestPointGrid grid(p.target, go);
      const double build = Since(t0);
      Points3 V = p.source.V;
      IcpOptions io;
      io.refined_query = refined;
      io.max_iterations = 100;
      IcpReport rep;
      Icp(V, grid, io, &rep);
      double vr, st;
      Errors(p, V, tq, &vr, &st);
      std::printf("%-30s %-22s %8.3f %8.3f %5d %12.2e %12.2e\n", p.name.c_str(),
                  refined ? "ours (refined query)" : "ours (paper 8-point)", build, rep.seconds, rep.iterations, vr,
                  st);
    }
    if (o3d) {
      WriteXyz(p.source.V, dir / "src.xyz");
      WriteXyz(p.target.V, dir / "dst.xyz");
      const fs::path out = dir / "out.txt";
      const std::string cmd = "/usr/bin/python3 " + SourceDir().string() + "/runtime/registration/open3d_icp.py " +
                              (dir / "src.xyz").string() + " " + (dir / "dst.xyz").string() + " 100 > " + out.string() +
                              " 2>/dev/null";
      if (std::system(cmd.c_str()) != 0) {
        std::printf("%-30s open3d failed\n", p.name.c_str());
        continue;
      }
      std::ifstream f(out);
      std::string key;
      double secs = 0, fitness = 0, rmse = 0;
      int iters = 0;
      Eigen::Matrix4d T;
      f >> key >> secs >> key >> fitness >> key >> rmse >> key >> iters >> key;
      for (int i = 0; i < 16; ++i) f >> T(i / 4, i % 4);
      Similarity s;
      s.rotation = T.topLeftCorner<3, 3>();
      s.translation = T.topRightCorner<3, 1>();
      double vr, st;
      Errors(p, s.Apply(p.source.V), tq, &vr, &st);
      std::printf("%-30s %-22s %8s %8.3f %5s %12.2e %12.2e\n", p.name.c_str(), "Open3D point-to-point", "(kd)", secs,
                  "≤100", vr, st);
    }
  }
}

void GridQueries() {
  std::printf("\n== Closest-point queries (per query) ==\n");
  const TriMesh target = testing::FlatTube(120, 90, 0.5, 0.7, 0.08);  // 10.8k v, 21.6k tris
  std::printf("target: %d vertices, %d triangles\n", target.NumVertices(), target.NumFaces());
  Rng rng(DeriveSeed(7, "bench-queries"));
  const int n = 200000;
  std::vector<Vec3> q(n);
  for (int i = 0; i < n; ++i) {
    const Vec3 v = target.V.row(rng.Below(target.NumVertices()));
    const double nx = rng.Normal(0, 0.01), ny = rng.Normal(0, 0.01), nz = rng.Normal(0, 0.01);
    q[i] = v + Vec3(nx, ny, nz);
  }
  for (int cells : {64, 96, 128}) {
    GridOptions go;
    go.cells = cells;
    auto t0 = Clock::now();
    const ClosestPointGrid grid(target, go);
    const double build = Since(t0);
    double sink = 0;
    t0 = Clock::now();
    for (const Vec3& p : q) sink += grid.Query(p).distance;
    const double tq = Since(t0) / n;
    t0 = Clock::now();
    for (const Vec3& p : q) sink += grid.QueryRefined(p).distance;
    const double tr = Since(t0) / n;
    const GridStats& s = grid.stats();
    std::printf(
        "grid %3d cells (%dx%dx%d, h=%.4f m): build %.3f s (band %.3f, sweep %.3f, %d passes); "
        "paper query %.0f ns, refined %.0f ns   [%g]\n",
        cells, s.nx, s.ny, s.nz, s.spacing, build, s.band_seconds, s.sweep_seconds, s.passes, tq * 1e9, tr * 1e9,
        sink > 0 ? 0.0 : 1.0);
  }
  auto t0 = Clock::now();
  const ExactClosestPoint exact(target);
  const double build = Since(t0);
  double sink = 0;
  t0 = Clock::now();
  for (const Vec3& p : q) sink += exact.Query(p).distance;
  std::printf("Embree BVH point query: build %.3f s, %.0f ns per query\n", build, Since(t0) / n * 1e9);
  const int nb = 300;
  t0 = Clock::now();
  for (int i = 0; i < nb; ++i) sink += BruteForceClosestPoint(target, q[i]).distance;
  std::printf("brute force: %.0f ns per query   [%g]\n", Since(t0) / nb * 1e9, sink > 0 ? 0.0 : 1.0);
}

void NonRigid() {
  std::printf("\n== Non-rigid step: secant LM vs plain LM (tube 1.7k v → smooth deformation) ==\n");
  const TriMesh tube = testing::FlatTube(48, 36, 0.5, 0.7, 0.08);
  const TriMesh target{testing::SmoothDeform(tube.V, 0.03, 6.0), tube.F};
  for (int mode = 0; mode < 3; ++mode) {
    RegistrationOptions o;
    o.lm.secant = mode != 0;
    o.lm.refresh_every = mode == 1 ? 5 : 10;
    const RegistrationEvaluation ev = RegisterAndEvaluate(tube, target, {}, o);
    const RegistrationReport& r = ev.report;
    std::printf(
        "%-22s S->T R %.5f R+N %.5f  T->S R+N %.5f | %2d it (%2d rejected) %2d fresh J, %2d secant | "
        "non-rigid %.2f s (factor %.2f, J %.2f, r %.2f)\n",
        mode == 0 ? "plain LM" : (mode == 1 ? "secant, refresh 5" : "secant, refresh 10"), ev.s_to_t_rigid.mean,
        ev.s_to_t_nonrigid.mean, ev.t_to_s_nonrigid.mean, r.lm.iterations, r.lm.rejected, r.lm.fresh_jacobians,
        r.lm.secant_updates, r.nonrigid_seconds, r.lm.factor_seconds, r.lm.jacobian_seconds, r.lm.residual_seconds);
  }
}
}  // namespace

int main(int argc, char** argv) {
  const std::string only = argc > 1 ? argv[1] : "";
  if (only.empty() || only == "icp") IcpComparison();
  if (only.empty() || only == "grid") GridQueries();
  if (only.empty() || only == "nonrigid") NonRigid();
  return 0;
}
