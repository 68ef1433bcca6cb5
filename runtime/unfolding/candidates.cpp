// Registration against recognition's top-k candidates (see candidates.h).
#include "runtime/unfolding/candidates.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/field_error.h"
#include "runtime/recognition/evaluate.h"

namespace drape::unfolding {

namespace rec = drape::recognition;

std::vector<rec::Candidate> RegistrationCandidates(const rec::Recognition& r, bool prior_kept, const std::string& aimed,
                                                   int k) {
  if (k < 1) throw Error("registration candidates: k must be >= 1 (got " + std::to_string(k) + ")");
  std::vector<rec::Candidate> out{r.best};
  auto listed = [&out](const rec::Candidate& c) {
    return std::any_of(out.begin(), out.end(), [&c](const rec::Candidate& o) { return o.entry == c.entry; });
  };
  auto of = [](const std::string& anchor) {
    std::vector<std::string> a = rec::SymmetryTwins(anchor);
    a.push_back(anchor);
    return a;
  };
  if (!prior_kept && !aimed.empty() && k > 1) {
    const std::vector<std::string> a = of(aimed);
    for (const rec::Candidate& c : r.entries) {
      if (std::find(a.begin(), a.end(), c.anchor) == a.end() || listed(c)) continue;
      out.push_back(c);
      break;
    }
  }
  const std::vector<std::string> accept = of(r.anchor);
  for (const rec::Candidate& c : r.entries) {
    if (static_cast<int>(out.size()) >= k) break;
    if (listed(c)) continue;
    if (prior_kept && std::find(accept.begin(), accept.end(), c.anchor) == accept.end()) continue;
    out.push_back(c);
  }
  return out;
}

CandidateRegistration RegisterCandidate(const TriMesh& source, const TriMesh& recon,
                                        const ExactClosestPoint& onto_recon, bool nonrigid) {
  CandidateRegistration c;
  registration::RegistrationOptions o;
  o.nonrigid = nonrigid;
  try {
    c.reg = registration::Register(source, recon, o);
  } catch (const NumericalError& e) {
    o.nonrigid = false;  // fall back to the rigid result
    c.reg = registration::Register(source, recon, o);
    c.note = std::string("non-rigid registration failed (") + e.what() + "); rigid used";
  }
  c.fit_rigid = SymmetricFit(c.reg.rigid, recon, onto_recon);
  c.fit_final = o.nonrigid ? SymmetricFit(c.reg.nonrigid, recon, onto_recon) : c.fit_rigid;
  return c;
}

void LowestPointOptions::Validate() const {
  if (!(tolerance >= 0 && tolerance < 0.5))
    BadField(tolerance, "LowestPointOptions.tolerance", "must be in [0, 0.5) m");
  if (!(floor_margin >= 0 && floor_margin < 0.5))
    BadField(floor_margin, "LowestPointOptions.floor_margin", "must be in [0, 0.5) m");
  if (!(lift >= 0 && lift < 0.2)) BadField(lift, "LowestPointOptions.lift", "must be in [0, 0.2) m");
  if (!(near_radius >= 0 && near_radius < 0.5))
    BadField(near_radius, "LowestPointOptions.near_radius", "must be in [0, 0.5) m");
}

bool AnchorIsLowest(const TriMesh& hang, int v, double tolerance, double radius) {
  if (v < 0 || v >= hang.NumVertices()) throw Error("lowest point: vertex " + std::to_string(v) + " outside the mesh");
  double lowest = hang.V(v, 1);
  for (Eigen::Index i = 0; i < hang.V.rows(); ++i)
    if (std::hypot(hang.V(i, 0) - hang.V(v, 0), hang.V(i, 2) - hang.V(v, 2)) <= radius)
      lowest = std::min(lowest, hang.V(i, 1));
  return hang.V(v, 1) - lowest <= tolerance;
}

namespace {
// The lowest vertex of `recon` (y up; the first of equals) among those within `radius`
// horizontally of `around` (none given: all); none when there is none or it lies within
// `floor_margin` of `floor_y`, where the fusion cut the garment. LowestPoint and LowestNear.
std::optional<Vec3> LowestVertex(const TriMesh& recon, const std::optional<Vec3>& around, double radius, double floor_y,
                                 double floor_margin) {
  std::optional<Vec3> best;
  for (Eigen::Index i = 0; i < recon.V.rows(); ++i) {
    const Vec3 p = recon.V.row(i).transpose();
    if (around && std::hypot(p.x() - around->x(), p.z() - around->z()) > radius) continue;
    if (!best || p.y() < best->y()) best = p;
  }
  if (best && best->y() - floor_y < floor_margin) return std::nullopt;
  return best;
}
}  // namespace

std::optional<Vec3> LowestPoint(const TriMesh& recon, double floor_y, const LowestPointOptions& o,
                                const std::optional<Vec3>& around) {
  std::optional<Vec3> p = LowestVertex(recon, around, o.near_radius, floor_y, o.floor_margin);
  if (p) p->y() += o.lift;
  return p;
}

void HangingEndOptions::Validate() const {
  if (!(radius > 0 && radius < 0.5)) BadField(radius, "HangingEndOptions.radius", "must be in (0, 0.5) m");
  if (!(floor_margin >= 0 && floor_margin < 0.5))
    BadField(floor_margin, "HangingEndOptions.floor_margin", "must be in [0, 0.5) m");
  if (!(min_drop >= 0 && min_drop <= 1)) BadField(min_drop, "HangingEndOptions.min_drop", "must be in [0, 1]");
  if (!(depth_window >= 0 && depth_window <= 0.1))
    BadField(depth_window, "HangingEndOptions.depth_window", "must be in [0, 0.1] m");
}

std::string HangingEnd(const std::string& anchor) {
  if (anchor == "left_elbow") return "left_cuff";
  if (anchor == "right_elbow") return "right_cuff";
  return "";
}

std::optional<Vec3> LowestNear(const TriMesh& recon, const Vec3& around, double floor_y, const HangingEndOptions& o) {
  return LowestVertex(recon, around, o.radius, floor_y, o.floor_margin);
}

int KeepCandidate(const std::vector<double>& fits) {
  int best = -1;
  for (int i = 0; i < static_cast<int>(fits.size()); ++i) {
    if (!(std::isfinite(fits[i]) && fits[i] >= 0)) continue;
    if (best < 0 || fits[i] < fits[best]) best = i;
  }
  return best;
}

}  // namespace drape::unfolding
