// Calibration of the non-central rig (calibration issue): from corner observations of known
// targets in a session's images, estimate the camera intrinsics and distortion, each mirror's
// decentre and tilt and the reflex plane's tilt and offset, starting from a model file (usually
// the ideal design), and say how sure we are.
//
// Pipeline (Calibrate):
//  1. every (image, target) placement gets an initial cam_from_target from the starting model's
//     rays (a central pose solve per ring, initial_pose.h), refined pose-only with the full model;
//  2. degenerate sessions are refused before solving (too few observations, all targets at one
//     range or in one azimuth sector, targets matching nothing);
//  3. a staged Ceres solve (intrinsics + poses, then the misalignment and the lens distortion,
//     then every group of `estimate`) with a robust loss on (a subset of) the corners only; then
//     the lip edge points, as normal points (their means over the images per 0.25 deg of each
//     edge), and weighted rounds without the robust loss (variance components, outlier
//     rejection) until the weights settle; a stage that ends worse than it began is undone;
//  4. the rig parameters' covariance by the Schur complement of the Jacobian (target poses
//     eliminated), scaled by the posterior variance factor; (nearly) unobservable parameters are
//     named with what data would fix them (covariance.h); held parameters that are not known
//     exactly (dist_p1, dist_p2, the lips' bias) are carried in as considered; dist_k3 is freed
//     only if the session's radii tell it from dist_k1, dist_k2. What a user should know about
//     the result (the camera frame's uncertain pointing, dist_k3) is said in words (notes).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/lip_edge_bias.h"
#include "calib/variance_components.h"
#include "model/calibration_settings.h"
#include "model/input_error.h"
#include "model/observations.h"
#include "model/rig_parameters.h"
#include "model/rig_params.h"
#include "model/target.h"

namespace omni::calib {

// The lips enter the solve as normal points: the means of each edge's points over the images per
// this much azimuth (observation_set.cc NormalLipPoints).
inline constexpr double kLipSpacingDeg = 0.25;

// A calibration that cannot be done with this input (degenerate session, no matches, a diverging
// solve); what() is one line naming the cause and what would fix it. An InputError so that the
// CLI reports it as bad input (exit 2).
class CalibrationError : public InputError {
 public:
  using InputError::InputError;
};

// The considered parameters' default sigmas: the tangential distortion (SolveRole::kTangential),
// 5e-4 each (a decent lens has |p| of a few 1e-4; 3e-4 turns the calibrated camera frame by ~0.09
// deg and moves the tilts along the camera-rotation valley by several noise sigmas).
std::map<std::string, double> DefaultConsideredSigmas();

struct CalibrationOptions {
  // Parameter groups to refine (blocks of model/rig_parameters.h); the others stay at the start.
  std::vector<std::string> estimate = DefaultEstimateBlocks();
  // Gaussian priors for refined mirror shapes (key mirror1_shape | mirror2_shape). A shape group
  // in `estimate` without a prior is refined freely.
  std::map<std::string, ShapePrior> priors;
  SolverOptions solver;
  bool refine_skew = false;     // the camera's skew is held at its starting value unless asked
  // dist_k3: refined if true; otherwise held unless the session's corners reach radii where it
  // is told from dist_k1, dist_k2 (decided after the solve from the covariance: freeing it may
  // at most double their sigmas; the rings' narrow radii usually hold it). result.solve.notes says.
  bool refine_dist_k3 = false;
  // dist_p1, dist_p2: held by default: over the rings' radii tangential distortion is nearly the
  // image of a rotation of the camera against the mirror bodies (sigma(cx) grew 5x with them free).
  bool refine_tangential = false;
  // Considered parameters: held coordinates of refined groups (dist_p1, dist_p2, dist_k3, skew)
  // that are not known exactly; the sigma given here for their held value is carried into the
  // covariance (calib/covariance.h). Default: DefaultConsideredSigmas().
  std::map<std::string, double> considered_sigma = DefaultConsideredSigmas();
  // Likewise each lip edge's detector bias (px), the same in every image (the rig does not
  // move): many images average the lips' noise but not their bias. The whole edge moved along u
  // and along v: this. 0: no lip bias considered at all.
  double lip_edge_bias_sigma_px = 0.03;
  // Across the edge: the larger of this floor and the constant part of the edge's residual pattern
  // along it (calib/lip_edge_bias.h). The floor is the detector's own constant offset, which no
  // pattern shows: against the exact lip images of 6 rendered rigs it was 0.004-0.052 px under the
  // realistic camera, 0.045-0.070 px on the webcam's blue edges (docs/experiments.md 2026-11-29
  // night); at 0.05 their offsets / sigma have an RMS of 0.9, at 0.03 of 1.4 (2.3 on the webcam).
  double lip_edge_offset_floor_px = 0.05;
  // Likewise a common detector offset of each ring's corners (px, per image axis): thousands of
  // corners average their noise to ~0.001 px but not an offset the detector makes everywhere
  // (measured on renders under the realistic camera's blur: tag corners 0.001-0.008 px per axis,
  // chessboards under 0.003; docs/experiments.md 2026-11-27), and data-rich parameters read it
  // (the reflex tilt ~0.1 deg per px of the inner ring's offset). 0: none.
  double corner_offset_sigma_px = 0.005;
  // Each mirror's profile (model/mirror_profile.h: a machined mirror's smooth departure from the
  // conic, sag_p1..sag_p4, sag_cos2, sag_sin2). "auto": freed, with a prior of profile_sigma_mm
  // per term around the starting model's value, for a mirror whose corners cover the radii the
  // profile acts on (ProfileCoverage) AND show a radial residual pattern with it held beyond
  // chance at the 1% level (ProfileDecision::evidence); otherwise held, and considered with that
  // sigma updated by what the data tell of the profile (Refinement::profile_updated: the
  // covariance the rig would have with it freed, the estimate the held profile's). A measured
  // profile (the start's measured_profile, a model file's profile_from) has its fit's covariance
  // as the prior instead (the tolerance stays on terms the scan did not measure) and is freed in
  // "auto" whatever the coverage. "free": always freed; "hold": always held and considered. A profile of microns bends rays by
  // milliradians: held at the conic, it hides in the mirrors' heights and the focal length while
  // the residuals stay at the noise (10 um moved both tz by 3 mm at 10 sigma).
  std::string profile = "auto";
  // A single mirror's non-central part (mirror1_pose in `estimate`: the mirror's tilt against the
  // lens and, with a perspective lens, the camera's offset from the mirror's focus). "auto": kept
  // only where the photos decide it (calib/central_decision.h: its departure from the start's
  // pose beyond chance at the 1% level and Schwarz's k ln n, or, where only the pixel noise
  // says so, better predictions of photos held out in a 3-fold cross-validation; the solve not
  // diverged);
  // otherwise the calibration holds the start's pose (the central model) and reports the
  // non-central fit's offset with its sigma. On Mei's 7-photo folds the free tilt (sigma 0.6
  // deg) fit the training photos and missed the held-out ones by 0.61 px against the central
  // model's 0.35, and the free perspective camera diverged (docs/experiments.md 2026-11-29
  // (night)). "free": the non-central fit whatever the test says.
  std::string noncentral = "auto";
  // A machined mirror's profile tolerance: the sigma of each term (half its peak-to-valley), mm.
  double profile_sigma_mm = 0.002;
  // Degeneracy checks on the target placements (horizontal range and azimuth of each target's
  // centre about the camera axis).
  // A target whose corners, triangulated by the calibrated rig's two rings, lie more than this
  // factor nearer or farther apart than its size (square, tag_size) gives stops the run: the
  // size or layout entered is not the one printed (right sizes measure within 0.1%; a page
  // printed "fit to page" is 3-6% small).
  double max_target_scale_error = 1.05;
  double max_target_scale_range_mm = 3000;  // placements triangulated farther are not used
  double min_range_ratio = 1.6;         // max range / min range must reach this (the initial
                                        // poses from the ideal model misjudge ranges by ~25%)
  double min_azimuth_span_deg = 120.0;  // the targets must span this much azimuth
  // Lip edge points (detections' lips, calib/lip_cost.h) as residuals besides the corners
  // (session `lips:`, default true).
  bool use_lips = true;
  // A single mirror's rim points as the image of a mirror circle of unknown radius (its measured
  // diameter not used: calib/lip_cost.h RimCirclePointCost); Calibrate sets it where the edge of
  // the mirror's image is not its rim.
  bool rim_radius_free = false;
  // Progress, one line per stage (the CLI prints it to stderr); may be empty.
  std::function<void(const std::string&)> progress;
  // What the solve is doing now ("stage alignment, iteration 12, rms 0.412 px"), called per
  // solver iteration for a terminal's status line (apps/progress.h); may be empty.
  std::function<void(const std::string&)> status;

  // Empty if the options are consistent, else what is wrong, naming the session key: an estimate
  // naming an unknown group or none, an unknown profile mode, a profile tolerance <= 0.
  std::string Check() const;
};

// One observation that was left out of the final solve, and why.
struct RejectedObservation {
  int image = 0;   // index into the detections' images
  int target = 0;  // session target index
  int id = 0;      // corner id
  int mirror = 1;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double residual_px = 0;  // norm of the reprojection error when rejected (0 if not projectable)
  std::string reason;      // "outlier" | "not projectable" | "placement failed"
};

// A corner used in the final solve and its reprojection residual there.
struct CornerResidual {
  int image = 0;   // index into the detections' images
  int target = 0;  // session target index
  int id = 0;      // corner id
  int mirror = 1;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();     // as detected
  Eigen::Vector2d residual = Eigen::Vector2d::Zero();  // projected - detected, px
};

// The corners' radial residuals along one mirror's radius: the mean residual along the image
// radius (away from the principal point) of the corners whose reflection point lies in each band
// of mirror radius. A profile error the model lacks shows as a smooth pattern here.
struct RadialResidualBin {
  double r_lo = 0, r_hi = 0;  // mirror radius band (mm, the mirror's body frame)
  int count = 0;
  double mean_px = 0, sem_px = 0;  // mean radial residual and its standard error
};
struct ProfileDecision {
  bool freed = false;
  // The start's profile was measured (profile_from): the prior on its terms, the scan's fit and
  // its covariance (MeasuredPriorCovariance; calib/profile_comparison.h compares).
  bool measured = false;
  std::array<double, kProfileTerms> prior_mean{};
  Eigen::Matrix<double, kProfileTerms, kProfileTerms> prior_covariance =
      Eigen::Matrix<double, kProfileTerms, kProfileTerms>::Zero();
  int bins_covered = 0, bins = 0;  // radial bands holding >= 10 corners
  double r_min = 0, r_max = 0;     // the radii the mirror's corners reach (mm): the bands' span
  // Before the profile was decided (held at the start) and at the end.
  std::vector<RadialResidualBin> pattern_before, pattern_after;
  // chi^2 of the band means against zero per band (~1 where no pattern is left), before / after.
  double pattern_chi2_before = 0, pattern_chi2_after = 0;
  // profile: auto: whether the pattern before (the profile held) is beyond chance at the 1%
  // level (its chi^2 over the covered bands against that quantile): the evidence that frees it.
  bool evidence = false;
  double evidence_threshold = 0;  // that quantile, per band
  // Held for want of evidence (auto): considered with its tolerance updated by the data
  // (Refinement::profile_updated).
  bool updated = false;
};

struct CalibrationResult;

// A single mirror's non-central part decided (CalibrationOptions::noncentral; central_decision.h).
struct NonCentralDecision {
  bool tested = false;   // a single rig with mirror1_pose in estimate, noncentral: auto
  bool decided = false;  // the photos decide the non-central part: the non-central fit stands
  // The Wald statistic of the determined pose coordinates' departure from the start's (the
  // central assembly) with the non-central fit's covariance, its degrees of freedom and the
  // threshold (the larger of its 99% quantile and k ln n).
  double chi2 = 0, threshold = 0;
  int dof = 0;
  // The same statistic with the pixel noise alone (the considered parameters left out). Where it
  // decides and the full one does not (the tilt in the camera-rotation valley that the held
  // tangential distortion opens), the photos arbitrate: 3-fold cross-validation, every photo
  // held out once, both models fit on the rest and scored on it (2-D RMS per corner, poses
  // solved); the non-central fit stands where it predicts the held-out photos better by more
  // than one standard error (below).
  double chi2_noise = 0;
  bool cross_validated = false;
  double cv_rms_noncentral_px = 0, cv_rms_central_px = 0;
  // The central model's held-out squared error less the non-central's, summed over the photos
  // (px^2), and its standard error from the photos' spread: the non-central fit stands only where
  // the gain exceeds its standard error (the one-standard-error rule).
  double cv_gain_px2 = 0, cv_gain_se_px2 = 0;
  std::vector<std::string> open;  // pose coordinates the non-central fit left undetermined
  std::string failure;            // the non-central solve's error (it diverged), else empty
  // The non-central fit where it solved (its offset and sigmas are reported either way).
  std::shared_ptr<const CalibrationResult> fit;
};

struct StageReport {
  std::string name;
  int iterations = 0;
  double initial_rms_px = 0, final_rms_px = 0;
  // The lip points' RMS (px) where the stage has them (n_lip_points > 0).
  double initial_lip_rms_px = 0, final_lip_rms_px = 0;
  int n_observations = 0, n_lip_points = 0;
  bool converged = false;
  // The stage ended worse than it began (its cost rose, or the corners' RMS rose by more than
  // 2%) and was undone: the parameters are those it started from.
  bool undone = false;
  std::string termination;  // Ceres' message
  double seconds = 0;
};

struct TargetPlacementEstimate {
  int image = 0, target = 0;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();  // cam_from_target, angle-axis
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  int observations[2] = {0, 0};  // used corners via mirror 1, mirror 2
};

// A parameter the data cannot determine, and what data would.
struct UnobservableParameter {
  std::string name;
  std::string hint;
};

// The calibrated rig and its refined parameters.
struct CalibrationEstimate {
  RigParams rig;  // the calibrated model (kind noncentral), rig.calibration = CalibrationInfoOf
  // Rig parameters that were refined, in covariance order (names as in rig.calibration).
  std::vector<std::string> names;
  Eigen::VectorXd values;  // internal units: px, unitless, rad, mm
};

// How sure the estimate is: the refined parameters' covariance (in the order of
// CalibrationEstimate::names), what went into it, and what the data cannot tell.
struct CalibrationUncertainty {
  Eigen::VectorXd sigma;  // internal units: px, unitless, rad, mm
  Eigen::MatrixXd covariance, correlation;
  // The sigmas and covariance from the pixel noise alone (without the considered parameters'
  // share).
  Eigen::VectorXd noise_sigma;
  Eigen::MatrixXd noise_covariance;
  // The held parameters whose uncertainty is in `covariance`: name, held value, assumed sigma.
  struct Considered {
    std::string name;
    double value = 0, sigma = 0;
  };
  std::vector<Considered> considered;
  // Each held, considered mirror profile: its prior and what the data tell of it (the model
  // file's calibration.held_profiles; design/tolerance.h decides its peak-to-valley from them).
  std::vector<HeldProfileInfo> held_profiles;
  int lip_edges_considered = 0;
  // Per considered lip edge (in the order of its columns): its residuals' pattern along it, from
  // which its bias across it is sized (calib/lip_edge_bias.h).
  std::vector<AlongEdgePattern> lip_edge_patterns;
  // Rings x axes whose corners' common offset is considered: the last considered columns, ring 1
  // u, v then ring 2 u, v (a ring without corners left out).
  int corner_offsets_considered = 0;
  // d value / d held value (rows: names) of each considered column: `considered` in order, then
  // the lip edges' biases, the rings' corner offsets (calib/projection_uncertainty.h), and the
  // sigma assumed for each.
  Eigen::MatrixXd considered_sensitivity;
  Eigen::VectorXd considered_column_sigma;
  // What each column is in the considered coordinates (columns x columns, unit columns): the
  // identity, except where a held profile's tolerance was updated by the data (profile: auto
  // without evidence): those columns are combinations of its terms (calib/covariance.h,
  // updated_considered). Empty: the identity.
  Eigen::MatrixXd considered_column_mix;
  // One name per considered column: the held parameter's, "lip <path> r <radius> across|u|v",
  // "corners ring <1|2> u|v".
  std::vector<std::string> considered_column_names;
  std::vector<UnobservableParameter> unobservable;  // named, never given a number
  // Every refined parameter (observable or not) and the eigen-decomposition of the
  // Jacobi-scaled (unit-diagonal) Schur complement over them, eigenvalues ascending: the
  // weakest directions of the data (a near-gauge shows as a tiny eigenvalue).
  std::vector<std::string> refined_names;
  Eigen::VectorXd schur_eigenvalues;
  Eigen::MatrixXd schur_eigenvectors;
  // Weighted SSR / (n_residuals - n_parameters) with each group weighted by 1 / its
  // weight_sigma_px^2: ~1 when the groups' noise was estimated right (lips: 1 / tau).
  double variance_factor = 1;
  // Per-group noise (corners ring 1, corners ring 2, lips) estimated from the residuals and used
  // as the groups' weights (calib/variance_components.h); the covariance is the inverse of the
  // normal matrix weighted with them.
  std::vector<VarianceComponent> variance_components;
};

// How the calibrated rig fits the observations of the final solve.
struct CalibrationResiduals {
  double rms_px = 0;
  double per_mirror_rms_px[2] = {0, 0};
  int n_observations = 0;  // corners used in the final solve
  int n_lip_points = 0;    // detected lip edge points used in the final solve
  int n_lip_rejected = 0;  // detected lip edge points left out (outliers, not projectable)
  // The normal points the used ones went into (their means over the images per azimuth bin of
  // each edge, calibrate.cc): the lip residuals of the solve.
  int n_lip_normal_points = 0;
  double lip_rms_px = 0;  // of the used detected points' distances across the edge
  std::vector<RejectedObservation> rejected;
  std::vector<CornerResidual> corners;  // every corner of the final solve
  std::vector<TargetPlacementEstimate> placements;
  // Each mirror's profile: freed or held, and the radial residual pattern (index 0: mirror 1).
  ProfileDecision profile[2];
};

// How the solve went: its stages, and what a user should know about it.
struct SolveReport {
  std::vector<StageReport> stages;
  bool converged = false;
  int n_parameters = 0;  // rig + pose parameters of the final solve
  // What a user of the model should know about this calibration, one sentence each (printed
  // under the table): dist_k3 held or refined and why, the camera's pointing against the mirror
  // bodies, the lips' considered bias.
  std::vector<std::string> notes;
  // A single mirror's rim was observed but left out: the edge of its image is not its rim
  // (Calibrate; model/single_rim.h RimEdgeIsTheRim at the mirror calibrated with it).
  bool rim_left_out = false;
  // Then: the radius (mm, at the calibrated scale) of the mirror circle the edge was fitted as
  // (CalibrationOptions::rim_radius_free), with its sigma; 0 where not.
  double rim_edge_radius_mm = 0, rim_edge_radius_sigma_mm = 0;
  // A single mirror's non-central part: tested, and kept or not (CalibrationOptions::noncentral).
  NonCentralDecision noncentral;
  // The data solved: the detections' image count and the session's targets in words
  // (TargetsDescription), as the model file's dataset records them.
  int images = 0;
  std::string targets;
};

// What Calibrate returns: the estimate, how sure it is, how it fits the observations, and how the
// solve went. The model file's `calibration:` section is derived from it (CalibrationInfoOf).
struct CalibrationResult {
  CalibrationEstimate estimate;
  CalibrationUncertainty uncertainty;
  CalibrationResiduals residuals;
  SolveReport solve;
};

// Where a calibration came from, beyond what the result knows (the model file's dataset session,
// tool_version, date): the command fills them; Calibrate leaves them empty.
struct CalibrationProvenance {
  std::string session;
  std::string tool_version;
  std::string date;
};

// The model file's `calibration:` section of a result: every field derived from it (and the
// provenance), so the model file says what the result says.
CalibrationInfo CalibrationInfoOf(const CalibrationResult& result,
                                  const CalibrationProvenance& provenance = {});

// Calibrates from detections (pixels of target corners per image and ring). `targets` are the
// session's targets (detections refer to them by index). Throws CalibrationError for degenerate
// or unusable input and for a solve that diverges; InputError for detections that refer to
// a target or corner id the session does not have.
CalibrationResult Calibrate(const RigParams& start, const std::vector<TargetSpec>& targets,
                            const Observations& detections, const CalibrationOptions& options);

// The session's targets in words ("chessboard 4x7, kalibr_aprilgrid 2x3"), as the calibrated
// model's dataset: records them.
std::string TargetsDescription(const std::vector<TargetSpec>& targets);

// The rig parameters' names, blocks and units: model/rig_parameters.h (BlockParameterNames,
// ParameterOf).

// The table printed after a calibration: parameter, value, sigma (and truth if given) in assembly
// units (px, mm, deg), then the unobservable parameters with hints, residual statistics, stages.
std::string ResultTable(const CalibrationResult& result, const RigParams* truth = nullptr);

}  // namespace omni::calib
