// The calibration's steps (calib/ only; the interface is calibrate.h): free functions over the
// data of calibration_data.h, in the order Calibrate() (calibrate.cc) calls them. Each takes what
// it reads as const and what it changes by pointer. By file:
//   observation_set.cc   collecting corners and lip points, pose initialisation, the robust
//                        stages' corner subset, lip azimuths and normal points, reprojection,
//                        residual RMS, degeneracy and target-scale checks
//   problem.cc           BuildProblem: each observation's cost wired to the rig's blocks and its
//                        placement's pose (or its azimuth), the priors, the held coordinates
//   stages.cc            the stage table, one stage's solve, outliers, variance components,
//                        divergence
//   solve_covariance.cc  ComputeCovariance of a solved problem and its considered columns; the
//                        dist_k3 decision; the camera-pointing note
//   profiles.cc          the mirrors' profiles: set up, decided, finished
//   calibrate.cc         Calibrate(): the robust stages, the weighted rounds, the covariance, the
//                        result
#pragma once

#include <array>
#include <set>
#include <string>
#include <vector>

#include "calib/calibration_data.h"

namespace omni::calib {

// The name of each considered column of the profiles held for want of evidence (profile: auto),
// followed by " 1", " 2", ...: the factors of their tolerance updated by the data.
inline constexpr char kHeldProfileColumn[] = "held profiles, updated by the data: combination";

inline void Progress(const CalibrationOptions& options, const std::string& line) {
  if (options.progress) options.progress(line);
}
inline void Status(const CalibrationOptions& options, const std::string& now) {
  if (options.status) options.status(now);
}

// ---- Set-up (calibrate.cc, profiles.cc) ----

// What options ask to refine (the profiles are added by SetUpProfiles).
Refinement RefinementOf(const CalibrationOptions& options);
// A single-mirror rig: mirror 2, the reflex and mirror 2's profile left out of the groups (said
// in the progress), a telecentric lens's mirror translation held, and R (the scale) held unless
// a prior on mirror1_shape gives its sigma or the rim is observed (`rim_observed`: RimObserved).
void RestrictToRig(const RigParams& rig, Refinement* refined, const CalibrationOptions& options,
                   bool rim_observed = false);
// Whether the detections hold a single mirror's rim (mirror 1's r_outer circle seen directly:
// detectors/lips/rim_edge.h) and the options use the lips.
bool RimObserved(const Observations& detections, const CalibrationOptions& options);
// The rig's blocks from `params` and the fixed data of its costs with the relaxed bounds.
RigState RigStateOf(const RigParams& params);
// The profiles in the problem from the start: a mirror without one gets the zero profile over its
// used radii (in *rig), held and considered until DecideProfiles (in *refined).
ProfileState SetUpProfiles(const RigParams& start, const CalibrationOptions& options,
                           RigParams* rig, Refinement* refined);

// ---- Observations (observation_set.cc) ----

// The detections' corners (and, with options.use_lips, lip points) and one placement per target
// seen in an image; throws InputError / CalibrationError on detections that do not fit.
ObservationSet CollectObservations(const Observations& detections,
                                   const std::vector<TargetSpec>& targets, const RigParams& rig,
                                   const CalibrationOptions& options);
// Each placement's pose from the starting model's rays, refined pose-only; failed placements'
// corners rejected.
void InitialisePoses(RigState* rig, const CalibrationOptions& options,
                     ObservationSet* observations, CostCache* costs);
// Refuses a session too small for its unknowns; a session whose targets sit at one range or in
// one azimuth sector is refused too, or (geometry_warns) said in a warning.
void CheckDegeneracy(const ObservationSet& observations, const std::vector<TargetSpec>& targets,
                     const RigBlockSet& groups, const CalibrationOptions& options,
                     bool geometry_warns = false);
// Throws where a target's size (square, tag_size) is off by more than
// options.max_target_scale_error from what the rig's stereo measures of it.
void CheckTargetScales(const RigParams& rig, const ObservationSet& observations,
                       const std::vector<TargetSpec>& targets, const CalibrationOptions& options);
// Marks the corners the robust stages solve with (Observation::in_robust_stages).
void SelectRobustStageCorners(std::vector<Observation>* corners);
void InitialiseLipAzimuths(const RigState& rig, std::vector<LipObservation>* lips);
// Appends the normal points (the means of each azimuth bin's points over the images) and marks
// the detected points unused (or rejected).
void NormalLipPoints(const CalibrationOptions& options, std::vector<LipObservation>* lips);

bool Reproject(const RigState& rig, const ObservationSet& observations, const Observation& corner,
               Eigen::Vector2d* pixel);
// Reproject, and the radius (mirror's body frame) where the corner's path meets its mirror.
bool ReprojectOnMirror(const RigState& rig, const ObservationSet& observations,
                       const Observation& corner, Eigen::Vector2d* pixel, double* radius);
bool ReprojectLip(const RigState& rig, const LipObservation& lip, Eigen::Vector2d* pixel);
// The corners' reprojection RMS (mirror 0: both rings), and their count.
double CornerRms(const RigState& rig, const ObservationSet& observations, int mirror, int* count);
// A lip point's circle height at the rig's current values (a single mirror's rim: the conic's
// sag at its radius, model/single_rim.h; otherwise the collected lip.z).
double CurrentLipZ(const RigParams& rig, const LipObservation& lip);
// Each free-radius rim point's radius set to the session's rim circle radius block.
void SyncRimRadius(ObservationSet* observations);
double LipRms(const RigState& rig, const std::vector<LipObservation>& lips, int* count);
// The outermost used corner's radius in normalised image coordinates (at the current camera).
double OuterRadius(const RigParams& rig, const std::vector<Observation>& corners);

// ---- The problem (problem.cc) ----

// The coordinates a solve over `groups` holds by a subset manifold, per block (a block held
// whole is constant and left at 0): the Jacobian columns its costs need not compute.
BlockMasks HeldColumns(const RigBlockSet& groups, const Refinement& refined);
// Corner i's cost and lip point i's for a problem whose solve holds `held` (built once into
// costs, and anew once the rig's fixed data has changed).
ceres::CostFunction* CornerCost(const RigState& rig, const Observation& corner, size_t i,
                                const BlockMasks& held, CostCache* costs);
ceres::CostFunction* LipCost(const RigState& rig, const LipObservation& lip, size_t i,
                             const BlockMasks& held, CostCache* costs, bool radius_free = false);
// Corner i's residual over the rig's blocks and its placement's pose.
ceres::ResidualBlockId AddCornerResidual(size_t i, ceres::LossFunction* loss,
                                         const BlockMasks& held, RigState* rig,
                                         ObservationSet* observations, CostCache* costs,
                                         ceres::Problem* problem);

struct ProblemOptions {
  RigBlockSet groups;  // the blocks refined (their held coordinates aside); the others constant
  ceres::LossFunction* loss = nullptr;  // the robust loss, or nullptr: least squares
  Selection selection;
  // The costs leave out the Jacobian columns of the coordinates the solve holds (HeldColumns; a
  // subset manifold drops them anyway); false: every column (the covariance's considered ones).
  bool held_without_columns = false;
};
// Each selected observation's `projectable` at the current parameters: the step before
// BuildProblem (which reads it and changes no observation).
void MarkProjectable(const RigState& rig, const Selection& selection,
                     ObservationSet* observations);
// Every selected observation that is projectable (MarkProjectable), each group's residuals
// weighted with 1 / weights.sigma^2; the priors on the refined shapes and freed profiles. The
// rig's and the observations' blocks are the problem's parameter blocks (a solve changes them).
std::unique_ptr<CalibrationProblem> BuildProblem(RigState* rig, ObservationSet* observations,
                                                 const Weights& weights,
                                                 const Refinement& refined,
                                                 const ProblemOptions& options, CostCache* costs);

// ---- Stages (stages.cc) ----

// How a stage's solve stops.
struct StopRule {
  int iteration_cap = 0;            // 0: options.solver.max_iterations alone
  double initial_trust_region = 0;  // 0: Ceres' default
  // The cost is whitened (the weighted rounds): stop once a step lowers it by less than
  // kWeightedStepCost. Otherwise the tight tolerances of the robust stages.
  bool whitened = false;
  // Its answer is the calibration's: stopping at the iteration cap is not converging. A stage
  // before it that stops there is not a failure: the next goes on.
  bool answer = false;
};

// One solve of the calibration: the groups it refines, the loss, the observations, the stop rule.
struct Stage {
  const char* name;
  // Parameter groups (blocks) refined, of those the Refinement names; all of them when
  // all_groups.
  RigBlockSet groups;
  bool all_groups;
  bool robust;  // options.solver.loss; else weighted least squares
  Selection selection;
  StopRule stop;
};

// The robust stages (calib/stages.cc says why these): a stage whose groups are empty or those of
// the stage before is skipped.
extern const Stage kRobustStages[3];
// The weighted rounds: on the robust stages' corner subset while the weights still move, then
// with every corner (their answer).
extern const Stage kReweightStage, kFinalStage;
// Scoring with the model held (estimate: []): every corner, no robust loss, solved to the
// unweighted stop rule (the whitened one stops at once when the weights are still 1 px).
extern const Stage kScoreStage;

// The groups `stage` refines.
RigBlockSet StageGroups(const Stage& stage, const Refinement& refined);
// Solves `stage` from the current values; undoes it if it ends worse (StageReport::undone).
StageReport SolveStage(const Stage& stage, const CalibrationOptions& options,
                       const Weights& weights, const Refinement& refined, RigState* rig,
                       ObservationSet* observations, CostCache* costs);
// Rejects the selected corners (and, with selection.lips, lip points) beyond the outlier
// threshold; returns how many.
int RejectOutliers(const RigState& rig, const Weights& weights, const Selection& selection,
                   double outlier_px, ObservationSet* observations);
// Variance components from the current residuals (see variance_components.h): the groups'
// weights and robust noise. lip_correlation false: the lips weighted as if independent (tau 1).
void EstimateVarianceComponents(const RigState& rig, const ObservationSet& observations,
                                const Refinement& refined, bool corner_subset,
                                bool lip_correlation, Weights* weights);
// Throws where a parameter went beyond any assembly error.
void CheckDiverged(const RigParams& rig);

// ---- Covariance (solve_covariance.cc) ----

// The covariance of the refined parameters at the current solution, with the held coordinates
// and the detector's biases considered: fills result's names, values, sigmas, covariance,
// considered columns, unobservable. Returns what decides dist_k3 and the lip edges' sigmas.
CovarianceFindings ComputeCovariance(const Weights& weights, const Refinement& refined,
                                     const CalibrationOptions& options, RigState* rig,
                                     ObservationSet* observations, CostCache* costs,
                                     CalibrationResult* result);
// After ComputeCovariance: frees dist_k3 when the session's radii tell it from dist_k1, dist_k2
// (true: solve again); otherwise it stays held. Says which in result->solve.notes.
bool DecideDistK3(const CovarianceFindings& findings, const RigParams& rig,
                  const std::vector<Observation>& corners, const CalibrationOptions& options,
                  Refinement* refined, CalibrationResult* result);
// Adds the note on the camera frame's pointing.
void AddPointingNote(RigKind rig, CalibrationResult* result);

// ---- Profiles (profiles.cc) ----

// The radial residual pattern of mirror `mirror`'s corners at the current parameters.
std::vector<RadialResidualBin> RadialPattern(const RigState& rig,
                                             const ObservationSet& observations,
                                             const ProfileState& profiles, int mirror,
                                             double* chi2);
// Frees each mirror's profile where options.profile and the corners' radial coverage say so
// (fitting a profile's radii to its corners first); true if one was freed.
bool DecideProfiles(const ObservationSet& observations, const CalibrationOptions& options,
                    RigState* rig, ProfileState* profiles, Refinement* refined,
                    CalibrationResult* result);
// The result's notes on the profiles after the solve; a held zero profile dropped from the rig.
void FinishProfiles(const ObservationSet& observations, const ProfileState& profiles,
                    const CalibrationOptions& options, RigState* rig, CalibrationResult* result);

}  // namespace omni::calib
