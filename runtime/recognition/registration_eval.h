// Registration table of `drape eval` (paper Table "Registration results"): with the pose
// known, register each test entry's database mesh (source S: the train entry of the same
// category hanging from the same anchor, its hang.ply) to the test entry's reconstruction
// (target T: its recon.ply), both in the object frame (grasp at the origin), and report
// the paper's directed distances S→T and T→S for rigid-only (R) and rigid + non-rigid
// (R+N) registration, per garment (category / test instance) and on average, plus the
// anchor transfer error and the time per registration.
//
// Which database instance: the entry recognition matched when its anchor is right
// (per_query "both/learned", else "both/unweighted"), otherwise the train entry of the
// true anchor whose instance sorts first ("first_instance"). Each pair says which.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "common/json.h"
#include "common/mesh.h"
#include "generator/release/release.h"
#include "runtime/recognition/recognizer.h"
#include "runtime/registration/registration.h"

namespace drape::recognition {

struct RegistrationEvalOptions {
  registration::RegistrationOptions registration;  // grid threads are forced to 1 per pair
  int max_pairs_per_category = 0;                  // 0 = every test entry; else the first N by id per category
  int threads = 0;        // pairs run in parallel (<= 0: all cores); results do not depend on it
  void Validate() const;  // throws drape::Error naming the bad field
};

// One category's figure: source, target, R, R+N (object frame), anchors marked.
struct RegistrationFigure {
  std::string category, caption;
  TriMesh source, target, rigid, nonrigid;
  Vec3 anchor_truth = Vec3::Zero();  // true anchor on the test entry's hung mesh
  Vec3 anchor_rigid = Vec3::Zero(), anchor_nonrigid = Vec3::Zero();
  bool has_anchor = false;
};

struct RegistrationEvalResult {
  // report.json "registration": {"pairs": [...], "garments": [...], "average": {...},
  // "paper": {...}, "options", "skipped", "timing"}. Distances in metres, anchor errors in
  // cm, times in seconds (timing only).
  Json table;
  std::vector<RegistrationFigure> figures;  // one per category (its first pair), sorted
};

// `per_query` is EvalResult::report["per_query"] (may be empty/null: then every source is
// "first_instance"). Test entries whose category/anchor has no train entry, or whose
// meshes are missing, are skipped and listed. Throws drape::Error for bad options.
// A pair whose registration fails numerically is listed as failed, not thrown.
RegistrationEvalResult EvaluateRegistration(const Release& release, const Database& db, const Json& per_query,
                                            const std::string& split, const RegistrationEvalOptions& options);

// PNG bytes of one figure: four orthographic panels (seen from +z) side by side.
std::string RenderRegistrationFigure(const RegistrationFigure& figure);

// Renders every figure into DIR/registration_<category>.png; returns the file names.
std::vector<std::string> WriteRegistrationFigures(const RegistrationEvalResult& result,
                                                  const std::filesystem::path& dir);

}  // namespace drape::recognition
