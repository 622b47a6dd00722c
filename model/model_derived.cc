#include "model/model_derived.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "model/conic.h"
#include "model/rig_frames.h"

namespace omni {

namespace {

// The near focus's sag (conic.h); a conic without one (K > 0) is taken from its vertex's centre
// of curvature.
double NearFocusSag(const Conic<double>& conic) {
  double near = conic.R;
  conic.NearFocus(&near);
  return near;
}

// A single-mirror rig: its near focus (the viewpoint of a central camera; a sphere's centre) and
// axis in C; where the conic has a far focus (hyperboloid, ellipsoid), that too: a perspective
// camera is central exactly when its centre (C's origin) sits there.
ModelDerived SingleDerived(const RigParams& rig) {
  const Pose<double> cam_from_mirror1 = PoseFromBlock(rig.mirror1_pose.data());
  const Conic<double> conic{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
  ModelDerived out;
  out.focus1_in_cam =
      cam_from_mirror1 * Eigen::Vector3d(0, 0, rig.vertex_z + NearFocusSag(conic));
  out.axis1_in_cam = cam_from_mirror1.Rotate(Eigen::Vector3d::UnitZ());
  double far = 0;
  if (conic.FarFocus(&far)) {
    out.has_far_focus = true;
    out.far_focus1_in_cam = cam_from_mirror1 * Eigen::Vector3d(0, 0, rig.vertex_z + far);
  }
  return out;
}

}  // namespace

ModelDerived ComputeModelDerived(const RigParams& rig) {
  if (rig.Single()) return SingleDerived(rig);
  const Pose<double> cam_from_mirror1 = PoseFromBlock(rig.mirror1_pose.data());
  const Pose<double> cam_from_mirror2 = PoseFromBlock(rig.mirror2_pose.data());
  const Plane<double> reflex_in_cam =
      ReflexPlaneInCam(rig.mirror1_pose.data(), rig.reflex.data(), rig.d);
  const Eigen::Vector3d unit_z = Eigen::Vector3d::UnitZ();
  ModelDerived out;
  out.focus1_in_cam = Focus1InCam(rig.mirror1_pose.data(), rig.mirror1_shape.data());
  out.axis1_in_cam = cam_from_mirror1.Rotate(unit_z);
  out.focus2_in_cam = Focus2InCam(rig.mirror2_pose.data(), rig.mirror2_shape.data(), rig.d);
  out.axis2_in_cam = cam_from_mirror2.Rotate(unit_z);
  out.reflex_point_in_cam = reflex_in_cam.point;
  out.reflex_normal_in_cam = reflex_in_cam.normal;
  out.baseline = (out.focus1_in_cam - out.focus2_in_cam).norm();
  return out;
}

FieldOfView RigFieldOfView(const RigParams& rig) {
  if (!rig.Single()) return ComputeFieldOfView(rig.Design(), rig.r_ref, rig.r_cam);
  const Conic<double> conic{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
  const double near = NearFocusSag(conic);
  // The surface point at radius r lies s(r) above the vertex, the focus `near` above it.
  auto elevation = [&](double r) { return std::atan2(conic.Sag(r * r) - near, r); };
  const double at_cam = elevation(rig.r_cam), at_sys = elevation(rig.r_sys);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  FieldOfView f;
  f.theta1_min = std::min(at_cam, at_sys);
  f.theta1_max = std::max(at_cam, at_sys);
  f.alpha1 = f.theta1_max - f.theta1_min;
  f.theta2_min = f.theta2_max = nan;
  f.alpha2 = 0;
  f.theta_sys_min = f.theta1_min;
  f.theta_sys_max = f.theta1_max;
  f.alpha_sys = f.alpha1;
  f.theta_sroi_min = f.theta_sroi_max = f.alpha_sroi = nan;
  return f;
}

}  // namespace omni
