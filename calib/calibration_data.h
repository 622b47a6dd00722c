// The calibration's data (calib/ only; the interface is calibrate.h): plain structs that the
// steps of calibration_steps.h read and write, each passed to them explicitly.
//   RigState        the rig's parameter blocks (what the Ceres costs point at) and the fixed data
//                   the costs are built with (the validity bounds, relaxed for detected points)
//   ObservationSet  the corners, the lip points and the target placements (with their poses)
//   Refinement      which parameter groups and coordinates the solve refines, the considered
//                   sigmas of those it holds, the priors; changed by the profile and dist_k3
//                   decisions
//   Weights         each residual group's weight sigma and robust noise (variance components)
//   ProfileState    whether the start had each profile, and the radii the corners reach
//   CostCache       one Ceres cost per observation and use, built once and kept between problems
//   CalibrationProblem  a Ceres problem over these blocks, with the losses and priors it uses
//   CovarianceFindings  what a covariance tells the dist_k3 decision, the lip edges' sigmas
#pragma once

#include "calib/calibrate.h"

#include <ceres/ceres.h>

#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rig_cost.h"
#include "calib/variance_components.h"
#include "model/lip.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"

namespace omni::calib {

constexpr double kDeg = M_PI / 180.0;
// Corner costs' validity bounds relaxed by this (docs/design.md, Relaxed bounds).
constexpr double kBoundSlackMm = 2.0;
constexpr int kRobustStageCorners = 2000;  // see SelectRobustStageCorners
// The profile blocks of mirror 1 and mirror 2 (calib/profiles.cc).
inline constexpr RigBlockId kProfileGroups[2] = {kProfile1Block, kProfile2Block};

// The rig being solved for: its parameter blocks (params' arrays: the Ceres parameter blocks)
// and the fixed data its costs share. The fixed data is immutable once made: a change (a
// profile's radii fitted to the corners) makes new data, and the costs built with the old are
// built anew when next used (CostCache).
struct RigState {
  RigParams params;
  std::shared_ptr<const RigFixed> fixed;
  // A detected corner IS seen, so its cost only needs the validity bounds to keep the solver on
  // the right sheet and path: per mirror path, bounds relaxed by kBoundSlackMm (RigStateOf).
  std::shared_ptr<const RigFixed> corner_bounds[2];
  // The lip paths of mirror 1 (direct, via_mirror1) and of mirror 2 (via_reflex, via_mirror2):
  // bounds far relaxed (LipBounds).
  std::shared_ptr<const RigFixed> lip_bounds[2];
};

// The bounds a lip point's cost uses on `path`. The detector labelled each edge's path already,
// and the lips lie at the mirrors' rims, so the rim and disc bounds would only wall the solver in
// (an edge point whose reflection leaves the rim by a hair fails a trial step).
inline const std::shared_ptr<const RigFixed>& LipBounds(const RigState& rig, LipPath path) {
  return path == LipPath::kDirect || path == LipPath::kViaMirror1 ? rig.lip_bounds[0]
                                                                  : rig.lip_bounds[1];
}

// One corner observation: a target corner seen in one ring of one image.
struct Observation {
  int image = 0, target = 0, id = 0, mirror = 1;
  int placement = -1;
  Eigen::Vector2d pixel;
  Eigen::Vector3d corner_in_target;
  bool rejected = false;     // outlier or its placement failed: out for good
  bool projectable = true;   // at the current parameters (MarkProjectable, before each problem)
  bool in_robust_stages = true;  // one of the corners the robust stages solve with
};

// One lip edge point: the image of the point at azimuth phi (unknown, refined) on a lip circle
// along a path.
struct LipObservation {
  int image = 0;
  LipPath path = LipPath::kDirect;
  double radius = 0, z = 0;  // the circle in its mirror's body frame
  Eigen::Vector2d pixel;
  std::array<double, 1> phi{};  // the azimuth's parameter block
  bool rejected = false;
  bool unused = false;  // a detected point replaced by its bin's normal point (NormalLipPoints)
  int members = 1;      // a normal point: the detected points it is the mean of
  int normal = -1;      // a detected point: index of the normal point it went into
  double across = 0;    // signed distance across the edge from the curve (InitialiseLipAzimuths)
  bool projectable = true;  // as for a corner
  bool Used() const { return !rejected && !unused; }
};

// One target in one image, and its pose (refined with the rig).
struct Placement {
  int image = 0, target = 0;
  std::array<double, 6> cam_from_target{};  // the pose's parameter block
  bool failed = false;
};

// The observations: what the detections give, with the placements' poses and the lip points'
// azimuths (refined with the rig), and the corners left out so far.
struct ObservationSet {
  std::vector<Observation> corners;
  std::vector<LipObservation> lips;  // detected points, then (NormalLipPoints) the normal points
  std::vector<Placement> placements;
  std::vector<RejectedObservation> rejected;
  int n_images = 0;
  // A single mirror's edge that is not its rim (calib/lip_cost.h RimCirclePointCost): the radius
  // (mm, mirror 1's body) of the mirror circle it is, one block refined with the rig; each such
  // lip point's `radius` is kept equal to it (SyncRimRadius).
  bool rim_radius_free = false;
  std::array<double, 1> rim_radius{};
  bool RimRadiusFree(const LipObservation& l) const {
    return rim_radius_free && l.path == LipPath::kDirect;
  }
};

// Which observations a problem or a residual statistic takes.
struct Selection {
  bool corner_subset = false;  // only the robust stages' corners (in_robust_stages)
  bool lips = false;           // the lip points too (BuildProblem; the statistics always take them)
};

// What the solve refines: the parameter groups (blocks) and, within them, the coordinates held
// at their starting values; the held coordinates' considered sigmas; the priors on the refined
// shapes and profiles.
struct Refinement {
  RigBlockSet groups;  // options.estimate and the profile blocks (SetUpProfiles)
  bool skew = false, tangential = false;
  bool dist_k3 = false;                   // options.refine_dist_k3, or DecideDistK3
  bool profile_free[2] = {false, false};  // each mirror's profile refined (DecideProfiles)
  // Held by profile: auto for want of evidence (DecideProfiles): its considered columns carry the
  // machining tolerance updated by what the session's data tell of the profile (the posterior of
  // the tolerance given the data, RigCovarianceOptions::updated_considered), not the bare
  // tolerance.
  bool profile_updated[2] = {false, false};
  std::map<std::string, double> considered_sigma;  // options' and the held profiles'
  std::map<std::string, ShapePrior> shape_priors;  // options.priors
  // Their means: each mirror's shape in the starting model (the priors stay there while the
  // stages move the values).
  std::array<double, 2> shape_mean[2] = {};
  // A freed profile's prior: the machining tolerance about the starting model's profile, or, for
  // a measured one (the start's measured_profile), the fit's covariance (MeasuredPriorCovariance).
  std::array<double, kProfileTerms> profile_mean[2] = {};
  double profile_sigma_mm = 0;
  std::optional<Eigen::Matrix<double, kProfileTerms, kProfileTerms>> profile_covariance[2];
  // A telecentric lens (single-mirror rigs): the camera's position along its axis is no datum and
  // a lateral shift of the mirror is the principal point's, so mirror 1's tx, ty, tz stay.
  bool telecentric = false;
  // A single-mirror rig's scale datum: R held at the start's (the rim's measured diameter set
  // it) unless a prior on mirror1_shape's R says how well it is known or the rim is observed.
  // From corners alone a mirror twice the size twice as far looks the same to a nearly central
  // camera (and behind a telecentric lens the size trades with the magnification, fx in px per
  // mm); the rim's edge in the photos is a circle of the measured radius on the mirror itself,
  // which fixes the size against the focal length or the magnification.
  bool hold_mirror_size = false;
};

// The coordinates of `group`'s block that stay at their starting values.
std::vector<int> HeldCoordinates(const Refinement& refined, RigBlockId group);

// Per residual group (0: corners ring 1, 1: corners ring 2, 2: lips): the sigma each group is
// weighted with (px; 1 until the first variance component estimate, so the robust stages weigh
// every pixel alike) and the robust noise estimate behind the relative outlier threshold.
struct Weights {
  double sigma[3] = {1, 1, 1};
  double robust_sigma[3] = {0, 0, 0};  // 0: not estimated yet (outlier_px alone)
  std::vector<VarianceComponent> components;
};

// The profile decisions' state: whether the starting model had each mirror's profile, and the
// radii each mirror's corners reach (FitProfileRadiiToCorners).
struct ProfileState {
  bool given[2] = {false, false};
  double corner_radii[2][2] = {{0, 0}, {0, 0}};  // mm; {0, 0}: not measured
};

// One cost per corner and per lip point for each set of held coordinates a problem is built with
// (ProblemOptions::held: the costs give them no Jet slot, calib/slot_autodiff.h; none for the
// covariance, which needs every column), built on first use with the rig's fixed data of that
// time and built anew when the rig's fixed data has been replaced since.
struct CostCache {
  struct Cost {
    std::shared_ptr<const RigFixed> fixed;  // what it was built with
    std::unique_ptr<ceres::CostFunction> cost;
  };
  struct Costs {
    std::vector<Cost> corners, lips;
  };
  std::map<BlockMasks, Costs> by_held;
};

// A Ceres problem over the rig's blocks, the placements' poses and the lip azimuths
// (BuildProblem), with the losses and prior costs it points to (the problem owns none of them;
// the costs are the CostCache's).
struct CalibrationProblem {
  CalibrationProblem() : problem(ProblemOptions()) {}
  static ceres::Problem::Options ProblemOptions() {
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    return po;
  }
  std::vector<std::unique_ptr<ceres::LossFunction>> group_losses;      // per residual group
  std::map<int, std::unique_ptr<ceres::LossFunction>> lip_losses;      // per normal point's members
  std::vector<std::unique_ptr<ceres::CostFunction>> prior_costs;
  ceres::Problem problem;  // after what it points to: destroyed first
  int n_corners = 0, n_lips = 0;
  // The corners' then the lip points' residual blocks (two pixel rows each), and the priors'.
  std::vector<ceres::ResidualBlockId> pixel_blocks, prior_blocks;
};

// What a covariance found besides the result's sigmas: for a held dist_k3, its sigma if it were
// freed and the largest factor by which dist_k1's and dist_k2's sigmas would grow (DecideDistK3);
// the lip edges' considered bias sigmas (px).
struct CovarianceFindings {
  bool k3_evaluated = false;
  double k3_sigma = HUGE_VAL, k3_growth = 0;
  std::vector<double> lip_edge_sigma;
  double rim_radius_sigma = 0;  // a free rim circle radius's (mm; 0: none)
};

}  // namespace omni::calib
