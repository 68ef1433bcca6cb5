// A left/right twin discriminator that looks only where the front/back cue is
// (docs/recognition.md, "Twins told apart by the cue's fit"): an option after the pose
// match of recognizer.h.
//
// A garment hung from `left_X` looks like the one hung from `right_X` turned 180° about
// the gripper, but for small front/back cues: the shirts' front neckline 6 cm deeper than
// the back's, the trousers' back waist 3.5 cm higher (garments/anchors.md). A whole-shape
// registration residual picks the right twin no better than the bits, since the cue is
// drowned by the rest of the shape. Here, after recognition picks entry A (instance i,
// anchor a) whose anchor has a symmetry twin a' with an entry A' of the same instance,
// both hung meshes (turned by their Eq. match rotation) are registered rigidly onto the
// query's reconstruction (scale + ICP, runtime/registration) and compared only in the
// cue's region: the patches within `radius` of the registered cue anchors (CueAnchors:
// the neckline's `collar`, `left_neck`, `right_neck` for shirts, the waist's
// `waist_center`, `left_waist`, `right_waist` for trousers):
//
//   db     : mean distance of the registered mesh's patches near the cue to recon.ply,
//   recon  : mean distance of recon.ply's patches near the registered cue to the mesh,
//   both   : their mean,
//   db_signed, recon_signed, signed: the same means of distances signed along recon.ply's
//            outward normal (> 0 where the mesh lies outside the reconstruction: a layer
//            where the query has none, e.g. the twin's front neckline where the query's
//            back one is), and their mean; compared as they are (not their size),
//   whole  : SymmetricFit of the whole shapes (the reference this replaces).
//
// With `instances` 0 the residuals of every database instance that has both anchors are
// summed (the same pair registered per instance). The twin is taken when its residual r'
// is below (1 − margin) · r of the matched anchor (signed: r − r' > margin · the matched
// side's unsigned "both" residual); otherwise the bits' answer stays.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "common/closest_point.h"
#include "common/json.h"
#include "common/mesh.h"
#include "generator/release/release.h"
#include "runtime/recognition/evaluate.h"
#include "runtime/recognition/recognizer.h"

namespace drape::recognition {

enum class TwinDirection { kDbToRecon, kReconToDb, kBoth, kDbSigned, kReconSigned, kSigned, kWhole };
// "db", "recon", "both", "db_signed", "recon_signed", "signed", "whole"; ParseTwinDirection
// throws drape::Error on another name.
std::string TwinDirectionName(TwinDirection d);
TwinDirection ParseTwinDirection(const std::string& name);

// The defaults are the setting with the most right answers on train + calibration queries
// of paper 2.3.0 (`drape eval --twin-fit-selection`: 44 of 77 against the bits' 36), a
// maximum over 392 settings that a nested leave-one-out does not confirm (36 of 77: the
// bits' count); docs/recognition.md, "Twins told apart by the cue's fit". Off by default.
struct TwinFitOptions {
  double radius = 0.16;  // R (m): the cue region around each cue anchor
  TwinDirection direction = TwinDirection::kReconSigned;
  int instances = 1;      // 1: the matched entry's instance; 0: every instance with both anchors
  double margin = 0.05;   // the twin must fit better by this fraction (0 <= margin < 1)
  bool scale = true;      // registration's scale step (l_T / l_S)
  int threads = 1;        // sides (or queries) registered in parallel; results do not depend on it
  void Validate() const;  // throws drape::Error naming the bad field
};

// The cue anchors among a garment's anchor labels: the neckline's (`collar` and labels
// with a `neck` token) when it has any, else the waist's (labels with a `waist` token);
// empty when neither.
std::vector<std::string> CueAnchors(const std::vector<std::string>& anchors);

// The cue's residuals of one registered mesh (m); < 0 where the region held no patch.
struct CueResidual {
  double db_to_recon = -1, recon_to_db = -1;
  int db_samples = 0, recon_samples = 0;
  // Signed along recon.ply's outward face normals (m; valid where the samples are > 0).
  double db_signed = 0, recon_signed = 0;
};

// Residuals around the cue vertices `cue` (vertices of `registered`) within `radius`.
CueResidual MeasureCue(const TriMesh& registered, const std::vector<int>& cue, const TriMesh& recon,
                       const ExactClosestPoint& onto_recon, double radius);

// One database entry of the pair, registered onto the query.
struct TwinSide {
  int entry = -1;
  std::string id, instance, anchor;
  bool matched = false;          // the bits' anchor (else the twin)
  int rotation = 0;              // Eq. match rotation it was turned by
  double whole_fit = -1;         // SymmetricFit (m); < 0: not registered
  std::vector<CueResidual> cue;  // one per radius of TwinFit::radii
  std::string failure;           // why not registered
  double seconds = 0;            // timing only
};

struct TwinFit {
  std::string matched_anchor, twin_anchor;  // twin "" when the anchor has none in the database
  std::string matched_instance;
  int matched_entry = -1, twin_entry = -1;         // the twin's entry of the matched entry's instance
  std::string anchor;                              // decided
  int entry = -1;                                  // decided entry: matched_entry or twin_entry
  bool compared = false;                           // a pair was measured and compared
  bool switched = false;                           // the twin was taken
  double matched_residual = 0, twin_residual = 0;  // what was compared (sums over instances; when compared)
  std::vector<double> radii;                       // the radii measured (options.radius first)
  std::vector<TwinSide> sides;
  std::string note;    // why no pair was registered, when none was (no twin, no cue anchors)
  double seconds = 0;  // timing only
};

// The first symmetry twin of entry `entry`'s anchor that its garment instance has an
// entry of in the database; "" when none.
std::string TwinInDatabase(const Database& db, int entry);

// The vertices of `instance`'s cue anchors (from the database labels' anchor vertices).
std::vector<int> CueVertices(const Database& db, const std::string& instance);

// The decision from measured sides for `options` (radius index `r` of fit.radii):
// fills anchor, entry, switched and the residuals. A pair that cannot be compared (no
// twin, a side not registered, an empty region) keeps the matched answer.
void DecideTwin(TwinFit& fit, const TwinFitOptions& options, size_t r = 0);

// The whole step for the matched entry `matched` of a query (`matches`: its Eq. match
// against every entry; `instances`: the pose search's instances, empty = all), with
// its reconstruction `recon`. `radii` (optional): also measure these (selection).
TwinFit TwinByFit(const Database& db, const std::vector<Match>& matches, int matched,
                  const std::vector<std::string>& instances, const TriMesh& recon,
                  const std::function<TriMesh(int)>& hung_mesh, const TwinFitOptions& options,
                  const std::vector<double>& radii = {});

// Applies a decision to a recognition: the best candidate becomes the twin's entry.
void ApplyTwinFit(const Database& db, const std::vector<Match>& matches, const TwinFit& fit, Recognition& r);

Json ToJson(const TwinFit& fit);
Json ToJson(const TwinFitOptions& options);

// The step for release entry `entry`'s query `q`, recognised as `r` with options `o`, onto
// the entry's recon.ply; `r` takes the twin when it fits better (`drape recognize --entry
// --twin-fit` and the Python binding's twin_fit=True). Throws drape::Error when the entry
// has no recon.ply.
TwinFit EntryTwinByFit(const Release& release, const Database& db, const Code& q, const RecognizeOptions& o,
                       const std::string& entry, const TwinFitOptions& options, Recognition& r);

// `drape eval --twin-fit`: for every query (category known, both instances, learned —
// unweighted without weights — as the pose table's strict column), the pose with and
// without the discriminator. report.json "twin_fit".
Json EvaluateTwinFit(const Release& release, const Database& db, const Weights* weights,
                     const std::vector<EvalQuery>& queries, const TwinFitOptions& options);

// `drape eval --twin-fit-selection`: the settings chosen on train + calibration only —
// the calibration split against the whole database and every train entry against the
// other instances (categories with one instance left out); a grid of radius × direction
// × instances × margin counted by strict pose accuracy, beside the bits alone and the
// nested leave-one-out of the choice (selection.h).
Json SelectTwinFit(const Release& release, const Database& db, const Weights* weights,
                   const std::vector<LabelledCode>& calibration, int threads);

}  // namespace drape::recognition
