// The calibration solve's internals (calib/ only; the interface is calibrate.h): the
// observations it holds, and the Calibrator that initialises poses, builds the problem, runs the
// staged solve and the weighted rounds, and computes the covariance. Its methods are spread over
// calib/calibrator_*.cc by responsibility:
//   calibrator_observations.cc  collecting corners and lip points, pose initialisation, the
//                               corner subset, lip azimuths and normal points, degeneracy checks
//   calibrator_problem.cc       the Ceres problem, one stage's solve, residual statistics,
//                               variance components, outliers, divergence
//   calibrator_covariance.cc    the covariance, its notes (camera pointing, dist_k3)
//   calibrate.cc                Run(): the stages and rounds in order; Calibrate()
#pragma once

#include "calib/calibrate.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <sstream>
#include <thread>

#include <Eigen/Geometry>

#include "calib/corner_cost.h"
#include "calib/covariance.h"
#include "pose/initial_pose.h"
#include "calib/lip_cost.h"
#include "calib/variance_components.h"
#include "model/lip.h"
#include "model/rig_parameters.h"
#include "model/rig_model.h"

namespace omni::calib {

constexpr double kDeg = M_PI / 180.0;
// Corner costs' validity bounds relaxed by this (docs/design.md, Relaxed bounds).
constexpr double kBoundSlackMm = 2.0;
constexpr int kRobustStageCorners = 2000;  // see Calibrator::SelectRobustStageCorners

// One corner observation: a target corner seen in one ring of one image.
struct Observation {
  int image = 0, target = 0, id = 0, mirror = 1;
  int placement = -1;
  Eigen::Vector2d pixel;
  Eigen::Vector3d corner_in_target;
  bool rejected = false;     // outlier or its placement failed: out for good
  bool projectable = true;   // at the current parameters (re-checked each stage)
  bool in_robust_stages = true;  // one of the corners the robust stages solve with
};

// One lip edge point: the image of the point at azimuth phi (unknown, refined) on a lip circle
// along a path.
struct LipObservation {
  int image = 0;
  LipPath path = LipPath::kDirect;
  double radius = 0, z = 0;  // the circle in its mirror's body frame
  Eigen::Vector2d pixel;
  std::array<double, 1> phi{};
  bool rejected = false;
  bool unused = false;  // a detected point replaced by its bin's normal point (NormalLipPoints)
  int members = 1;      // a normal point: the detected points it is the mean of
  int normal = -1;      // a detected point: index of the normal point it went into
  double across = 0;    // signed distance across the edge from the curve (InitialiseLipAzimuths)
  bool projectable = true;
  bool Used() const { return !rejected && !unused; }
};

// One target in one image, and its pose (refined with the rig).
struct Placement {
  int image = 0, target = 0;
  std::array<double, 6> cam_from_target{};
  bool failed = false;
};

class Calibrator {
 public:
  Calibrator(const RigParams& start, const std::vector<TargetSpec>& targets,
             const Observations& detections, const CalibrationOptions& options)
      : rig_(start), targets_(targets), options_(options) {
    rig_.kind = ModelKind::kNoncentral;
    rig_.calibration.reset();
    SetUpProfiles(start);
    fixed_ = FixedOf(rig_);
    // A detected corner IS seen, so the costs only need the validity bounds to keep the solver
    // on the right sheet and path: they use bounds relaxed by kBoundSlackMm (mirror 1: larger
    // rim, smaller disc; mirror 2: larger rim, smaller hole, larger disc), so a corner near a
    // ring's edge does not fail a trial step while the parameters are still off.
    cost_fixed_[0] = cost_fixed_[1] = fixed_;
    // A detected point is seen: the mount's posts would only wall trial steps in.
    for (RigFixed& f : cost_fixed_) f.mount.present = false;
    for (RigFixed& f : cost_fixed_) f.r_sys += kBoundSlackMm;
    cost_fixed_[0].r_ref = std::max(0.0, fixed_.r_ref - kBoundSlackMm);
    cost_fixed_[0].reflex_side_slack = kBoundSlackMm;
    cost_fixed_[1].r_ref += kBoundSlackMm;
    cost_fixed_[1].r_cam = std::max(0.0, fixed_.r_cam - kBoundSlackMm);
    constexpr double kLipSlackMm = 30.0;
    lip_fixed_[0] = lip_fixed_[1] = fixed_;
    for (RigFixed& f : lip_fixed_) f.mount.present = false;
    for (RigFixed& f : lip_fixed_) f.r_sys += kLipSlackMm;
    lip_fixed_[0].r_ref = 0;  // direct, via_mirror1: no occlusion by the disc
    lip_fixed_[1].r_ref += kLipSlackMm;
    lip_fixed_[1].r_cam = 0;
    for (const auto& g : options_.estimate) estimate_.insert(g);
    refine_k3_ = options_.refine_dist_k3;
    Collect(detections);
    if (options_.use_lips) CollectLips(detections);
  }

  CalibrationResult Run();

 private:
  // Coordinates of a refined block that stay at their starting values.
  std::vector<int> HeldCoordinates(const std::string& group) const {
    std::vector<int> held;
    auto hold = [&](const char* name) {
      const RigParameter* p = FindRigParameter(name);
      if (group == p->block) held.push_back(p->index);
    };
    if (!options_.refine_skew) hold("skew");
    if (!options_.refine_tangential) hold("dist_p1"), hold("dist_p2");
    if (!refine_k3_) hold("dist_k3");
    for (int m = 0; m < 2; ++m) {
      if (group == kProfileGroups[m] && !profile_free_[m]) {
        for (int k = 0; k < kProfileTerms; ++k) held.push_back(k);
      }
    }
    return held;
  }
  static constexpr const char* kProfileGroups[2] = {"mirror1_profile", "mirror2_profile"};
  // The profiles in the problem from the start (calibrator_profile.cc): a mirror without one
  // gets the zero profile over its used radii, held and considered until DecideProfiles.
  void SetUpProfiles(const RigParams& start);
  // The radial residual pattern per mirror at the current parameters.
  std::vector<RadialResidualBin> RadialPattern(int mirror, double* chi2) const;
  // Frees each mirror's profile where options_.profile and the corners' radial coverage say so;
  // true if one was freed.
  bool DecideProfiles(CalibrationResult* result);
  // A profile's radii set to those mirror m's corners reach (the costs rebuilt with them).
  void FitProfileRadiiToCorners(int m);
  // The freed profiles' priors and the result's notes, after the solve.
  void FinishProfiles(CalibrationResult* result);
  void Status(const std::string& now) const {
    if (options_.status) options_.status(now);
  }
  void Progress(const std::string& line) const {
    if (options_.progress) options_.progress(line);
  }
  void Collect(const Observations& detections);
  void InitialisePoses();
  // Throws where a target's size (square, tag_size) is off by more than
  // options_.max_target_scale_error from what the rig's stereo measures of it.
  void CheckTargetScales() const;
  void CheckDegeneracy() const;
  bool Reproject(const Observation& obs, Eigen::Vector2d* pixel) const;
  // Reproject, and the radius (mirror's body frame) where the corner's path meets its mirror.
  bool ReprojectOnMirror(const Observation& obs, Eigen::Vector2d* pixel, double* radius) const;
  bool ReprojectLip(const LipObservation& lip, Eigen::Vector2d* pixel) const;
  const RigFixed& LipFixed(LipPath path) const {
    // The detector labelled each edge's path already, and the lips lie at the mirrors' rims, so
    // the rim and disc bounds would only wall the solver in (an edge point whose reflection
    // leaves the rim by a hair fails a trial step): lip residuals use the bounds far relaxed.
    return path == LipPath::kDirect || path == LipPath::kViaMirror1 ? lip_fixed_[0]
                                                                     : lip_fixed_[1];
  }
  void CollectLips(const Observations& detections);
  void InitialiseLipAzimuths();
  void NormalLipPoints();
  void SelectRobustStageCorners();
  double LipRms(int* count) const;
  double* PoseBlock(int placement) { return placements_[placement].cam_from_target.data(); }
  ceres::CostFunction* CostOf(size_t i);
  // Corner i's residual over the rig blocks and its placement's pose.
  ceres::ResidualBlockId AddCorner(ceres::Problem* problem, size_t i, ceres::LossFunction* loss);
  // Adds every usable observation (and the shape priors) to `problem`; returns the count.
  int BuildProblem(ceres::Problem* problem, const std::set<std::string>& groups,
                   ceres::LossFunction* loss, std::vector<ceres::ResidualBlockId>* corner_blocks,
                   std::vector<ceres::ResidualBlockId>* prior_blocks);
  StageReport Solve(const std::string& name, const std::set<std::string>& groups, bool robust);
  // lips false: corners only (the lips' residuals are not fitted yet).
  int RejectOutliers(bool lips = true);
  // Variance components from the current residuals (see variance_components.h); sets the
  // groups' weights and robust noise.
  // lip_correlation false: the lips weighted as if independent (tau 1), see Run().
  void EstimateVarianceComponents(bool lip_correlation = true);
  double Rms(int mirror, int* count) const;  // mirror 0: both
  void Covariance(CalibrationResult* result);
  // The outermost used corner's radius in normalised image coordinates (at the current camera).
  double OuterRadius() const;
  // After Covariance(): frees dist_k3 when the session's radii tell it from dist_k1, dist_k2
  // (true: solve again); otherwise it stays held. Says which in result->notes.
  bool DecideDistK3(CalibrationResult* result);
  void CheckDiverged() const;

  RigParams rig_;
  RigFixed fixed_;
  RigFixed cost_fixed_[2];  // per mirror path, relaxed bounds (see the constructor)
  RigFixed lip_fixed_[2];   // for the lip paths of mirror 1 / mirror 2 (see LipFixed)
  std::vector<TargetSpec> targets_;
  CalibrationOptions options_;
  std::set<std::string> estimate_;
  bool refine_k3_ = false;  // dist_k3 refined (options_.refine_dist_k3, or DecideDistK3)
  bool profile_free_[2] = {false, false};  // each mirror's profile refined (DecideProfiles)
  bool profile_given_[2] = {false, false};  // the starting model had a profile
  std::array<double, kProfileTerms> profile_start_[2];  // its values: the priors' means
  double corner_radii_[2][2] = {{0, 0}, {0, 0}};  // the radii each mirror's corners reach (mm)
  // What the last Covariance() found for a held dist_k3 if it were freed: its sigma and the
  // largest factor by which dist_k1's and dist_k2's sigmas would grow.
  struct {
    bool evaluated = false;
    double sigma = HUGE_VAL, growth = 0;
  } k3_probe_;
  std::vector<Observation> obs_;
  std::vector<LipObservation> lips_;
  std::vector<std::unique_ptr<ceres::CostFunction>> lip_costs_;
  int last_n_lips_ = 0;  // lip residuals added by the last BuildProblem
  // Lip points enter the problem only once the corners have solved the rig and the groups'
  // noise is estimated (Run()).
  bool lips_in_solve_ = false;
  // The robust stages solve with a subset of the corners (SelectRobustStageCorners).
  bool robust_subset_only_ = false;
  std::vector<Placement> placements_;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs_;
  // The coordinates of the camera and distortion blocks the running solve holds (bit k:
  // coordinate k): the costs give them no Jet slot (calib/slot_autodiff.h). Set by Solve() for
  // its solve only; 0 otherwise, so other evaluations (the covariance) get every column.
  uint32_t held_camera_ = 0, held_distortion_ = 0;
  std::vector<std::unique_ptr<ceres::CostFunction>> prior_costs_;
  std::vector<RejectedObservation> rejected_;
  int n_images_ = 0;
  // Per residual group (0: corners ring 1, 1: corners ring 2, 2: lips): the sigma each group is
  // weighted with (px; 1 until the first variance component estimate, so the robust stages weigh
  // every pixel alike) and the robust noise estimate behind the relative outlier threshold.
  double weight_sigma_[3] = {1, 1, 1};
  double robust_sigma_[3] = {0, 0, 0};  // 0: not estimated yet (outlier_px alone)
  std::vector<std::unique_ptr<ceres::LossFunction>> group_losses_;
  std::map<int, std::unique_ptr<ceres::LossFunction>> lip_losses_;  // per normal point's members
  std::vector<VarianceComponent> components_;
  std::vector<double> lip_edge_sigma_;  // the lip edges' considered bias sigmas (Covariance())
};

// Adds the note on the camera frame's pointing (calibrator_covariance.cc).
void AddPointingNote(CalibrationResult* result);

}  // namespace omni::calib
