// Assembly tolerances in the rig's body: the parts against each other, as an assembler sets
// them, rather than against the camera. Mirror 1's body (it carries the reflex disc) is the
// reference and its axis the rig's axis; every quantity is in its frame M1:
//   mirror2.decentre_to_mirror1  mirror 2's vertex off mirror 1's axis, |(x, y)|          mm
//   mirror2.tilt_to_mirror1      mirror 2's axis against mirror 1's, |(x, y)| of its
//                                direction (the small tilt angle)                          rad
//   mirror2.spacing              mirror 2's vertex along mirror 1's axis, less the design's mm
//   camera.decentre_to_axis      the camera's centre off mirror 1's axis                   mm
//   camera.tilt_to_axis          the camera's optical axis against mirror 1's              rad
// (the reflex plane's tilt and offset are in M1 already: tolerance.h's reflex checks).
// Why: turning the camera against the bodies moves every tilt and lateral shift measured in the
// camera's frame together with the principal point (the camera-rotation valley), so a session
// cannot decide them; the parts against each other do not move with the camera's turn, and only
// the camera's own pointing (camera.tilt_to_axis) stays in that valley.
// Sigmas: first order, the quantities' Jacobian by central differences over the pose blocks.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "design/named_covariance.h"
#include "design/tolerance.h"
#include "model/rig_params.h"

namespace omni::design {

struct RigBodyQuantities {
  Eigen::Vector2d mirror2_decentre_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d mirror2_tilt_rad = Eigen::Vector2d::Zero();
  double mirror2_spacing_mm = 0;
  Eigen::Vector2d camera_decentre_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d camera_tilt_rad = Eigen::Vector2d::Zero();
};
RigBodyQuantities RigBodyQuantitiesOf(const RigParams& rig);

// The checks of `tolerance`'s limits (those >= 0), undecided until CheckTolerances decides them,
// each with frame "mirror1", its sigma where the model has a covariance and its strongest
// correlation with the principal point (the camera's tilt lies in the camera-rotation valley).
std::vector<ToleranceCheck> CheckRigBody(const RigParams& rig, const RigBodyTolerance& tolerance,
                                         const NamedCovariance& cov);

// Correction() for a check of frame "mirror1": which way to move the part, in mirror 1's frame.
std::string RigBodyCorrection(const ToleranceCheck& check);

}  // namespace omni::design
