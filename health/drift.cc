#include "health/drift.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "model/rig_frames.h"
#include "model/rig_parameters.h"

namespace omni::health {
namespace {

// The coordinates that are no rig parameters: the camera's rigid motion in its mount (not a
// parameter of the model file but a change of both cam_from_mirror), in the camera's group.
struct MountMode {
  const char* name;
  bool rotation;  // a rotation (rad) about the axis, else a translation (mm) along it
  int axis;       // of C: 0 x, 1 y, 2 z
};
constexpr MountMode kMountModes[] = {{"camera.rx", true, 0},  {"camera.ry", true, 1},
                                     {"camera.rz", true, 2},  {"camera.tx", false, 0},
                                     {"camera.ty", false, 1}, {"camera.tz", false, 2}};
constexpr const char* kMountGroup = kRigBlocks[kCameraBlock].group;

// The tilt (rx, ry) whose rotation takes +z to `axis` (rig_frames.h: R(rx, ry, 0) e_z =
// (ry s, -rx s, cos theta) / theta scaled: rotation about (rx, ry, 0) / theta by theta).
Eigen::Vector2d TiltOfAxis(const Eigen::Vector3d& axis) {
  const Eigen::Vector3d a = axis.normalized();
  const double theta = std::acos(std::clamp(a.z(), -1.0, 1.0));
  const double s = std::sin(theta);
  if (s < 1e-15) return Eigen::Vector2d::Zero();
  return Eigen::Vector2d(-a.y() / s * theta, a.x() / s * theta);
}

// Applies the camera's rigid motion in its mount (point_in_cam' = dR point_in_cam + dt) to one
// mirror's pose block [rx, ry, tx, ty, tz]; returns the spin about the body's axis that the
// block cannot hold (rad), for the reflex tilt of mirror 1.
double MoveMirrorPose(const Eigen::Matrix3d& dR, const Eigen::Vector3d& dt, double* pose) {
  const Eigen::Matrix3d R = RotationFromTilt(pose[kRx], pose[kRy]);
  const Eigen::Matrix3d moved = dR * R;
  const Eigen::Vector2d tilt = TiltOfAxis(moved.col(2));
  const Eigen::Vector3d t = dR * Eigen::Vector3d(pose[kTx], pose[kTy], pose[kTz]) + dt;
  pose[kRx] = tilt.x(), pose[kRy] = tilt.y();
  pose[kTx] = t.x(), pose[kTy] = t.y(), pose[kTz] = t.z();
  // moved = R(tilt) * Rz(spin): the body's old axes seen in its new spin-free frame.
  const Eigen::Matrix3d spin = RotationFromTilt(tilt.x(), tilt.y()).transpose() * moved;
  return std::atan2(spin(1, 0), spin(0, 0));
}

}  // namespace

const std::vector<std::string>& DriftGroups() {
  // The groups of the table's drift parameters (model/rig_parameters.h), in the table's order.
  static const std::vector<std::string> groups = [] {
    std::vector<std::string> out;
    for (const RigParameter& p : RigParameterTable()) {
      if (p.drift && std::find(out.begin(), out.end(), GroupOf(p)) == out.end()) {
        out.push_back(GroupOf(p));
      }
    }
    return out;
  }();
  return groups;
}

const std::vector<DriftCoordinate>& DriftCoordinates() {
  // Group by group: the table's drift parameters, then the mount's modes.
  static const std::vector<DriftCoordinate> coordinates = [] {
    std::vector<DriftCoordinate> c;
    for (const std::string& group : DriftGroups()) {
      for (const RigParameter& p : RigParameterTable()) {
        if (p.drift && group == GroupOf(p)) c.push_back({p.name, group, DriftStep(p.unit)});
      }
      if (group != kMountGroup) continue;
      for (const MountMode& m : kMountModes) {
        const ParameterUnit unit = m.rotation ? ParameterUnit::kRadian : ParameterUnit::kMillimetre;
        c.push_back({m.name, group, DriftStep(unit), false, m.rotation, m.axis});
      }
    }
    return c;
  }();
  return coordinates;
}

int DriftCoordinateIndex(const std::string& name) {
  const auto& all = DriftCoordinates();
  for (size_t i = 0; i < all.size(); ++i) {
    if (all[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<int> CoordinatesOf(const std::string& group) {
  std::vector<int> indices;
  const auto& all = DriftCoordinates();
  for (int i = 0; i < static_cast<int>(all.size()); ++i) {
    if (group.empty() || all[i].group == group) indices.push_back(i);
  }
  return indices;
}

RigParams ApplyDrift(const RigParams& rig, const std::vector<int>& coordinates,
                     const Eigen::VectorXd& amounts) {
  RigParams moved = rig;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero(), translation = Eigen::Vector3d::Zero();
  bool mount = false;
  const auto& all = DriftCoordinates();
  for (size_t k = 0; k < coordinates.size(); ++k) {
    const DriftCoordinate& c = all[coordinates[k]];
    const double a = amounts[static_cast<int>(k)];
    if (c.rig_parameter) {
      *ParameterOf(&moved, c.name) += a;
      continue;
    }
    mount = true;
    (c.mount_rotation ? rotation : translation)[c.mount_axis] += a;
  }
  if (mount) {
    const double angle = rotation.norm();
    const Eigen::Matrix3d dR =
        angle > 0 ? Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix()
                  : Eigen::Matrix3d::Identity();
    const double spin1 = MoveMirrorPose(dR, translation, moved.mirror1_pose.data());
    MoveMirrorPose(dR, translation, moved.mirror2_pose.data());
    // The reflex normal is given in mirror 1's body; the body's new frame is its old one turned
    // by -spin about the axis, so the normal's coordinates turn by +spin.
    const Eigen::Vector3d normal = RotationFromTilt(moved.reflex[kReflexRx], moved.reflex[kReflexRy]) *
                                   Eigen::Vector3d(0, 0, 1);
    const Eigen::Vector2d tilt = TiltOfAxis(Eigen::AngleAxisd(spin1, Eigen::Vector3d::UnitZ()) * normal);
    moved.reflex[kReflexRx] = tilt.x(), moved.reflex[kReflexRy] = tilt.y();
  }
  return moved;
}

}  // namespace omni::health
