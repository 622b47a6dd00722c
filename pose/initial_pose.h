// Initial target poses from a model's rays (calibration step 1; guided detection's seeding ring). Each ring of a
// central (or nearly central) rig is a central camera at its mirror's primary focus F_i
// [bp_ray1_wrt_F1], [bp_ray2_wrt_F2]: the rays of a placement's corners are rotated so their mean
// is +z, read as normalised coordinates of a virtual pinhole camera at F_i and handed to a planar
// PnP solve (OpenCV IPPE); the rotation and the offset F_i are then undone.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "model/rig_model.h"

namespace omni {

struct PoseGuess {
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();  // cam_from_target, angle-axis
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

// cam_from_target from one ring's observations of one planar target (corners in the target's
// z = 0 plane). False if fewer than 4 pixels back-project through `mirror` or the PnP fails.
bool CentralPoseFromRing(const RigModel& start, Mirror mirror,
                         const std::vector<Eigen::Vector3d>& corners_in_target,
                         const std::vector<Eigen::Vector2d>& pixels, PoseGuess* pose);

}  // namespace omni
