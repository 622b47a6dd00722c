// The central approximations (central_fit.h) in other packages' calibration files:
//  - Kalibr's camchain YAML: cam0 = ring 1 (mirror 1, outer), cam1 = ring 2 (mirror 2, inner),
//    camera_model omni, intrinsics [xi, fu, fv, pu, pv], distortion_model radtan,
//    distortion_coeffs [k1, k2, r1, r2], resolution [w, h]; T_cn_cnm1 (cam1 from cam0) and
//    T_cam_imu (the camera from the rig frame, which takes the IMU's place), 4x4, metres.
//  - basalt's calibration JSON (cereal): value0.T_imu_cam (each camera's pose in the rig frame:
//    px, py, pz in metres, qx, qy, qz, qw), intrinsics (camera_type "ds": fx, fy, cx, cy, xi,
//    alpha), resolution, and the IMU fields basalt's reader expects, neutral (no IMU).
// A single-mirror rig has one ring: cam0 alone (no T_cn_cnm1), one basalt camera.
// The fit's residuals are written beside them as comments (YAML) or an "omnistereo" member
// (JSON) so that a user sees what the approximation costs where it is used.
#pragma once

#include <vector>
#include <string>

#include "exports/central_fit.h"

namespace omni::exports {

// `source` names the model file (written into the header comment); `frame` the rig frame.
std::string KalibrCamchainYaml(const std::vector<CentralRing>& rings, int width, int height,
                               const std::string& source, ReferenceBody frame);
std::string BasaltCalibrationJson(const std::vector<CentralRing>& rings, int width, int height,
                                  const std::string& source, ReferenceBody frame);

}  // namespace omni::exports
