// Registration against recognition's top-k candidates (docs/unfolding.md, "Top-k
// registration candidates"): the regrasp point is predicted from the database entry
// whose registration fits the reconstruction best, not from recognition's first entry
// alone. One hang tells a garment's left/right twins, neighbouring anchors and database
// instances apart poorly (strict pose accuracy ~40–47 % on the paper release), while a
// wrong entry registered onto the reconstruction carries its anchor elsewhere.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "common/closest_point.h"
#include "common/mesh.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/registration/registration.h"

namespace drape::unfolding {

// The database entries to register, best first: recognition's answer `r.best` (after the
// plan prior), then the next entries of `r.entries` (the category's entries ranked by
// recognition's weighted Hamming distance, any anchor or instance, the twin included,
// without the pose height gate) up to `k` in all. When `prior_kept` (the plan prior chose
// the anchor), only entries of r.anchor or a symmetry twin of it follow: the arm knows
// where it was sent, the candidates decide the database instance and the side. When the
// last regrasp aimed at `aimed` but the prior was not kept (recognition did not rank it
// among its top anchors), the best entry of `aimed` or its twin comes second: the fit
// decides between recognition and the arm. k = 1 is recognition's answer alone. Throws
// drape::Error if k < 1.
std::vector<recognition::Candidate> RegistrationCandidates(const recognition::Recognition& r, bool prior_kept,
                                                           const std::string& aimed, int k);

// How well a registered database mesh fits the reconstruction: registration.h
// SymmetricFit (the symmetric mean of the paper's two directed errors), metres.
using registration::SymmetricFit;

// The lowest point (LoopOptions::lowest; Osawa et al. and Cusumano-Towner et al., whom
// the paper cites, regrasp a hanging garment at its lowest point). A garment hangs with
// one place lowest, and where the database hang has the target there (a trouser leg's end
// below a held leg end or knee), the reconstruction's lowest point is observed directly,
// while the registered anchor carries the difference between the database's hang and
// this one (docs/unfolding.md, "The lowest point"). The IR scan then gives the depth along
// the approach only, the grasp stays at the scan's centre: the point was observed, and
// the LoG search for a fold would move it sideways, off the corner.
struct LowestPointOptions {
  double tolerance = 0.03;     // m: the anchor is the hang's lowest when at most this above its lowest vertex
  double floor_margin = 0.02;  // m: a lowest point this near the region's floor is the cut, not the garment's
  double lift = 0.02;          // m: the point goes this far above the lowest (the jaws are 2 cm tall)
  // m: the lowest point near the target. When the hang's target (or its twin) is not its
  // lowest point but the lowest of the hang within this distance of itself (horizontally;
  // a leg's hem corner beside a lower waist), the regrasp point is the reconstruction's
  // lowest vertex within this distance of the registered target, `lift` above it. Shorts
  // held by the crotch on paper 2.3.0: the registered leg end 7-27 cm off on the pattern
  // in all 11 such first steps of 60 trials; the lowest near it within 6 cm in 6 of them
  // (docs/unfolding.md, "The lowest point near the target"). 0: off.
  double near_radius = 0.06;
  void Validate() const;  // throws drape::Error naming the bad field
};
// Whether vertex `v` of `hang` (y up) lies within `tolerance` of the height of the lowest
// vertex within `radius` of it horizontally (infinite: of the whole hang).
bool AnchorIsLowest(const TriMesh& hang, int v, double tolerance,
                    double radius = std::numeric_limits<double>::infinity());
// The lowest vertex of the reconstruction (y up), `lift` above it; none when the
// reconstruction is empty or its lowest vertex lies within `floor_margin` of `floor_y`
// (the segmentation region's floor, where the fusion cut the garment). With `around`:
// the lowest within `near_radius` of it horizontally.
std::optional<Vec3> LowestPoint(const TriMesh& recon, double floor_y, const LowestPointOptions& o,
                                const std::optional<Vec3>& around = std::nullopt);

// The hanging end (LoopOptions::hanging). A long-sleeve shirt's elbow is never a hang's
// lowest point, but the forearm below it hangs straight down to the cuff whenever the
// sleeve is free, while the registered elbow carries the database-versus-trial hang
// difference (docs/unfolding.md, "The hanging end"). The cuff is observed as the
// reconstruction's lowest point near where the registration puts it, and the elbow is
// placed the pattern's elbow-to-cuff distance above. As with the lowest point, the IR scan
// gives the depth only.
struct HangingEndOptions {
  double radius = 0.10;        // m: horizontal search radius around the registered end
  double floor_margin = 0.02;  // m: as LowestPointOptions::floor_margin
  // The database hang must have the end at least this fraction of the pattern distance
  // below the anchor (its forearm hangs down too); otherwise the rule does not apply.
  double min_drop = 0.5;
  // The depth from the nearest IR reading within this distance (m) across the scan of its
  // centre (RefineOptions::depth_half_width_samples): the point lies on a sleeve's side,
  // and a centre beam that passed the sleeve read the body behind it 16-18 cm deeper in 3
  // of 16 steps on paper 2.3.0 (docs/unfolding.md, "The hanging end"). 0: the centre's own.
  double depth_window = 0.02;
  void Validate() const;  // throws drape::Error naming the bad field
};
// The free end that hangs straight below `anchor` ("left_elbow" -> "left_cuff"), or "" when
// the anchor has none.
std::string HangingEnd(const std::string& anchor);
// The lowest vertex of the reconstruction (y up) within `radius` horizontally of `around`;
// none when no vertex lies there or the lowest lies within `floor_margin` of `floor_y`.
std::optional<Vec3> LowestNear(const TriMesh& recon, const Vec3& around, double floor_y, const HangingEndOptions& o);

// One candidate registered: `Register` (rigid, then non-rigid when `nonrigid`; a
// non-rigid breakdown falls back to the rigid result with `note` set) and the fit of the
// rigid and of the final mesh (= rigid when rigid-only).
struct CandidateRegistration {
  registration::RegistrationResult reg;
  const TriMesh& final_mesh() const { return reg.nonrigid; }  // == reg.rigid when rigid-only
  double fit_rigid = -1, fit_final = -1;                      // SymmetricFit, m
  std::string note;
};
// `source` is the database mesh already turned by the candidate's rotation.
CandidateRegistration RegisterCandidate(const TriMesh& source, const TriMesh& recon,
                                        const ExactClosestPoint& onto_recon, bool nonrigid);

// Index of the smallest fit (ties: the earlier, i.e. recognition's better rank); fits
// < 0 or not finite are skipped (a candidate that could not be registered or planned).
// -1 if none is usable.
int KeepCandidate(const std::vector<double>& fits);

}  // namespace drape::unfolding
