// The ways a calibrated rig can move after its calibration (a knock, a crash), as small changes
// of the stored model: what the in-field check fits to name the group that moved, and what the
// target-free refinement estimates.
//
// Groups:
//   camera   the camera against both mirrors: its intrinsics fx, fy, cx, cy (a lens knocked or
//            refocused) and its pose in the mount, a rigid motion applied to both cam_from_mirror
//            (camera.rx, ry, rz, tx, ty, tz in C; the mirrors' spin it adds is carried into
//            mirror 1's reflex tilt, so the disc stays where it was in the body);
//   mirror1  mirror 1's body against the camera (mirror1.rx, ry, tx, ty, tz); the reflex disc,
//            part of that body, moves with it;
//   mirror2  mirror 2 against the camera (mirror2.*);
//   reflex   the reflex disc in mirror 1's body (reflex.rx, ry, dz).
// The rig parameters among them, their groups and their order are the parameter table's
// (model/rig_parameters.h: RigParameter::drift, RigBlock::group); the camera's mount motion is
// drift.cc's own. Every coordinate is in the rig's internal units (px, rad, mm); `step` is its
// finite-difference step, about 1% of a typical knock (DriftStep of its unit).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/rig_params.h"

namespace omni::health {

struct DriftCoordinate {
  std::string name;   // "fx", "camera.rz", "mirror2.tx", "reflex.dz" (rig parameter names)
  std::string group;  // camera | mirror1 | mirror2 | reflex
  double step = 0;
  bool rig_parameter = true;  // a parameter of the model file (false: camera.* mount motion)
  // The camera's move in its mount (rig_parameter false): a rotation (rad) or a translation (mm)
  // about / along this axis of C (0 x, 1 y, 2 z).
  bool mount_rotation = false;
  int mount_axis = 0;
};

// Every coordinate, grouped in the order above.
const std::vector<DriftCoordinate>& DriftCoordinates();
// The group names in order.
const std::vector<std::string>& DriftGroups();
// The index into DriftCoordinates() of the coordinate of that name; -1 if there is none.
int DriftCoordinateIndex(const std::string& name);
// Indices into DriftCoordinates() of a group's coordinates (all for "").
std::vector<int> CoordinatesOf(const std::string& group);

// `rig` moved by `amounts` along the coordinates `coordinates` (indices into DriftCoordinates()).
RigParams ApplyDrift(const RigParams& rig, const std::vector<int>& coordinates,
                     const Eigen::VectorXd& amounts);

}  // namespace omni::health
