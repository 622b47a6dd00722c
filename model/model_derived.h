// What a rig's pose blocks mean in the camera frame C (a model file's `derived:` section, for
// people and other tools): the mirrors' foci and axes, the reflex plane, the baseline.
#pragma once

#include <Eigen/Core>

#include "model/ideal_analysis.h"
#include "model/rig_params.h"

namespace omni {

// A single-mirror rig: focus1 is its mirror's near focus (a sphere's centre), far_focus1 the
// other one where the conic has it; the mirror-2 and reflex members are zero.
struct ModelDerived {
  Eigen::Vector3d focus1_in_cam = Eigen::Vector3d::Zero();  // mirror 1's primary focus, (0,0,c1) in M1
  Eigen::Vector3d axis1_in_cam = Eigen::Vector3d::Zero();   // mirror 1's axis, cam_from_mirror1 rotation * (0,0,1)
  Eigen::Vector3d focus2_in_cam = Eigen::Vector3d::Zero();  // mirror 2's primary focus, (0,0,d-c2) in M2
  Eigen::Vector3d axis2_in_cam = Eigen::Vector3d::Zero();
  Eigen::Vector3d reflex_point_in_cam = Eigen::Vector3d::Zero();   // the reflex plane's point (0,0,d/2+dz in M1)
  Eigen::Vector3d reflex_normal_in_cam = Eigen::Vector3d::Zero();  // its unit normal (nominally (0,0,-1))
  double baseline = 0;                   // |focus1 - focus2|
  bool has_far_focus = false;            // single-mirror rigs
  Eigen::Vector3d far_focus1_in_cam = Eigen::Vector3d::Zero();
};
ModelDerived ComputeModelDerived(const RigParams& rig);

// A rig's elevation limits (rad; each ring's directions seen from its viewpoint, in its mirror's
// body), the one place panoramas, their exports, the central fits and stereo take them from:
//  - folded: ComputeFieldOfView(rig.Design(), rig.r_ref, rig.r_cam) ([vFOV_system]);
//  - single: its one ring seen from the mirror's near focus (focus1 above) at the surface points
//    between r_cam and r_sys: theta1_min/max, alpha1 = alpha_sys, theta_sys = theta1; the
//    mirror-2 and stereo-ROI members NaN and alpha2 0 (there is no second ring).
FieldOfView RigFieldOfView(const RigParams& rig);

}  // namespace omni
