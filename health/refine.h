// Target-free refinement from natural images (`omnistereo refine`): re-estimate what
// moved since the calibration from what check.h measures, with covariance.
//
// What the natural scene determines: the ring-to-ring matches fix the geometry of mirror 2 and
// the reflex disc against mirror 1 across the epipolar direction (a match's gap; its range along
// the ray is free), the lip edges fix each mirror body's image against the camera (their known
// circles), so together they determine the camera intrinsics fx, fy, cx, cy and the poses of
// both mirrors and the disc, up to what a session's lips and depth spread leave free. Which
// parameters that is for a given set of photos is decided from the data, as calibrate does
// (calib/covariance.h): the Jacobian of the check's bins by the candidate parameters, whitened by
// the bins' errors, is analysed; parameters in its null space or whose sigma exceeds the rig
// parameter table's bound are held at the stored values and named with what would determine
// them. The distortion and the mirror shapes are never refined here (a knock does not change
// them, and nothing in a natural scene separates them from the poses).
//
// The solve (Ceres, Levenberg-Marquardt) runs on the samples themselves (a spread subsample of
// the check's kept ones), weighted by their kind's scatter: each match's exact ray gap under the
// moving model, each lip point's distance to its edge at the azimuth of the nearest point, which
// is found again (the lips re-linearised) between `rounds` solves. The covariance comes from the
// check's bins at the solution (their errors include the floors for what stays correlated along
// an arc), scaled up by their chi^2 per degree of freedom where that exceeds 1.
//
// A single mirror (one ring): the evidence is the rim's edge where the calibration photos
// measured it (check.h); the rim shows five numbers (its scale, shift and tilt), so the named
// group alone is refined (camera or mirror1: the rim cannot tell them apart), its determinable
// coordinates picked greedily (a shift and a tilt move the rim nearly alike: one is held), and the
// bins' covariance includes what the scene behind the rim moves its harmonics by in each photo.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "health/check.h"
#include "model/input_error.h"
#include "model/rig_params.h"

namespace omni::health {

// Refinement cannot be done with these photos (too little texture, nothing observable); what()
// is one line naming the cause and what would fix it.
class RefineError : public InputError {
 public:
  using InputError::InputError;
};

struct RefineOptions {
  // Groups whose rig parameters may be refined (drift.h; the camera's move in its mount is the
  // mirrors' poses moving together, so the camera group contributes fx, fy, cx, cy here).
  // Empty: the group the check names (and its runner-up): a natural scene determines a few
  // parameters well, and freeing all of them spreads one mirror's move over the others.
  std::vector<std::string> groups;
  CheckOptions check;
  int max_match_samples = 3000;  // in the solve (a spread subsample)
  int max_lip_samples = 3000;
  int rounds = 2;                // solves, the lips re-linearised between them
  int max_iterations = 30;       // per solve
  std::function<void(const std::string&)> status;  // what it is doing now (may be empty)
};

struct RefinedParameter {
  std::string name;
  double before = 0, after = 0, sigma = 0;  // internal units (px, rad, mm)
};

struct HeldParameter {
  std::string name;
  std::string hint;  // what would determine it
};

struct RefineResult {
  std::vector<std::string> groups;  // those refined (the check's choice if none were given)
  RigParams rig;  // the stored model with the refined values; calibration: updated (see .cc)
  std::vector<RefinedParameter> refined;
  std::vector<HeldParameter> held;  // candidates the photos cannot determine
  Eigen::MatrixXd covariance;       // over `refined`, internal units
  double variance_factor = 1;       // chi^2 / dof of the bins after the solve (applied if > 1)
  CheckResult before, after;        // the check under the stored and the refined model
  int iterations = 0;
  double seconds = 0;
};

RefineResult RefineRig(const RigParams& stored, const std::vector<ImageEvidence>& images,
                       const RefineOptions& options = {});

}  // namespace omni::health
