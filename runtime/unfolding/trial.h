// One trial of the regrasping loop on a simulated world, phase by phase (step.h). Private
// to drape_unfolding: RunTrial (loop.h) is the interface. Each phase is one file:
// pickup.cpp, observe.cpp, recognise.cpp, plan.cpp, regrasp.cpp; truth.cpp measures a
// step against the simulated garment for evaluation; loop.cpp runs the phases in turn.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "common/closest_point.h"
#include "generator/feature/feature.h"
#include "runtime/hardware/sim.h"
#include "runtime/unfolding/loop.h"

namespace drape::unfolding {

class Trial {
 public:
  using Progress = std::function<void(const std::string&)>;
  // `o` with its sensing height resolved (not 0); `world` holds the category's test garment.
  Trial(const ReleaseModel& model, const std::string& category, const LoopOptions& o, uint64_t seed,
        hardware::SimWorld& world, TrialResult& res, const Progress& progress);
  // Pick-up, then steps until both grippers keep hold or max_regrasps; fills res.steps,
  // res.converged, res.final_f, res.regrasps, res.failure and the stage times.
  void Run();

 private:
  // pickup.cpp: the seeded random first grasp, carried to the sensing pose.
  void PickUp();
  // observe.cpp: the turning sweep, its fusion and feature (false, with res.failure, when
  // the reconstruction is empty); the cloth as it hung (truth).
  bool Observe(Step& s, int iteration, Feature* code);
  void RecordCloth(Step& s, const hardware::GripperPose& holder) const;
  // recognise.cpp: the category (by registration at every hang) and the held anchor, the
  // plan prior.
  void Recognise(Step& s, const Feature& code);
  bool UpdateCategory(Step& s, const std::vector<recognition::Match>& matches,
                      const recognition::Recognizer& recognizer, const recognition::RecognizeOptions& ro);
  void ApplyPlanPrior(Step& s) const;
  // plan.cpp: the registration candidates, the kept one's plan and the regrasp point
  // (false, with res.failure, when no candidate gives a plan).
  bool Plan(Step& s);
  struct Registered;  // the candidates' registrations (plan.cpp)
  void RegisterCandidates(Step& s, const std::vector<recognition::Candidate>& cands,
                          const std::vector<DesiredPair>& pairs, const ExactClosestPoint& onto, Registered& r) const;
  void NonrigidForKept(Step& s, const ExactClosestPoint& onto, Registered& r) const;
  std::string PlanFrom(const recognition::Candidate& c, const std::vector<DesiredPair>& pairs, double* f,
                       std::string* why) const;
  void ColourByScore(Step& s, const std::vector<DesiredPair>& pairs) const;
  void PointFromKept(Step& s, const CandidateRegistration& reg, int v, const Registered& r) const;
  bool TargetIsLowest(const TriMesh& hang, int v, const CandidateTrace& c, double radius) const;
  void PointFromLowest(Step& s, const CandidateRegistration& reg, int v, const Registered& r) const;
  void PointFromHangingEnd(Step& s, const CandidateRegistration& reg, const CandidateTrace& c,
                           const Registered& r) const;
  TriMesh TurnedSource(const recognition::Candidate& c) const;
  // regrasp.cpp: the IR scan and the free gripper's grasp (false on a miss); letting go.
  bool Regrasp(Step& s, int free_arm);
  hardware::GripperPose Refine(Step& s, int free_arm);
  void LetGo(Step& s, int free_arm);
  // loop.cpp: at f ≥ ξ, whether the hang just sensed supports the belief (s.verify);
  // records the truth of a loop that would have declared here.
  bool Verify(Step& s, int step);
  // truth.cpp (evaluation only): the step's errors against the simulated garment.
  void MeasureAgainstTruth(Step& s) const;
  void MeasureClosing(Step& s, const hardware::GripperPose& g) const;

  void Say(const std::string& s) const;

  const ReleaseModel& model_;
  const std::string& category_;
  const LoopOptions& o_;
  uint64_t seed_;
  hardware::SimWorld& world_;
  TrialResult& res_;
  const Progress& progress_;
  int holder_ = 0;
  std::string trial_category_;     // the category the hangs so far decide
  std::string aimed_;              // the anchor the holding gripper was sent to ("" before a regrasp)
  bool holder_regrasped_ = false;  // the holder took its point by an aimed regrasp (not the first grasp)
  std::vector<std::map<std::string, double>> fit_scores_;  // each hang's category-by-registration scores
};

// The arms' poses between phases.
hardware::GripperPose SensingPose(double height);  // the holder while the garment turns
hardware::GripperPose Home(int arm);               // a free arm out of the way
// Appends to a step's note ("; " between notes).
void AddNote(Step& s, const std::string& text);

}  // namespace drape::unfolding
