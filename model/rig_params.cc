#include "model/rig_params.h"

#include "model/ideal_analysis.h"

namespace omni {

RigParams MakeIdealRig(const DesignParams& theta, double r_cam, const Pinhole<double>& cam,
                       int image_width, int image_height) {
  RigParams rig;
  rig.kind = ModelKind::kIdeal;
  rig.image_width = image_width;
  rig.image_height = image_height;
  rig.camera = {cam.fx, cam.fy, cam.cx, cam.cy, cam.skew};
  rig.mirror1_shape = {theta.c1, theta.k1};
  rig.mirror2_shape = {theta.c2, theta.k2};
  rig.d = theta.d;
  rig.r_sys = theta.r_sys;
  rig.r_ref = ReflexRadius(theta);
  rig.r_cam = r_cam;
  const auto m1 = HyperboloidSheet<double>::Mirror1(theta.c1, theta.k1);
  const auto m2 = HyperboloidSheet<double>::Mirror2(theta.c2, theta.k2, theta.d);
  rig.lip1 = Lip{"blue", theta.r_sys, theta.r_sys + 3.0, m1.Z(theta.r_sys)};
  rig.lip2 = Lip{"red", theta.r_sys, theta.r_sys + 3.0, m2.Z(theta.r_sys)};
  return rig;
}

RigParams MakeSingleRig(const Conic<double>& mirror, LensKind lens, double vertex_z, double r_sys,
                        double r_cam, const Pinhole<double>& cam, int image_width,
                        int image_height) {
  RigParams rig;
  rig.kind = ModelKind::kIdeal;
  rig.rig = RigKind::kSingle;
  rig.lens = lens;
  rig.image_width = image_width;
  rig.image_height = image_height;
  rig.camera = {cam.fx, cam.fy, cam.cx, cam.cy, cam.skew};
  rig.mirror1_shape = {mirror.R, mirror.K};
  rig.vertex_z = vertex_z;
  rig.r_sys = r_sys;
  rig.r_cam = r_cam;
  rig.lip1 = Lip{"", r_sys, r_sys, vertex_z + mirror.Sag(r_sys * r_sys)};
  return rig;
}

bool HasLip(const RigParams& rig, Mirror mirror) {
  if (rig.Single() && mirror == Mirror::kTwo) return false;
  return !(mirror == Mirror::kOne ? rig.lip1 : rig.lip2).color.empty();
}

RigBlocks<double> RigBlocksOf(const RigParams& rig) {
  RigBlocks<double> b;
  b[kCameraBlock] = rig.camera.data();
  b[kDistortionBlock] = rig.distortion.data();
  b[kShape1Block] = rig.mirror1_shape.data();
  b[kShape2Block] = rig.mirror2_shape.data();
  b[kPose1Block] = rig.mirror1_pose.data();
  b[kPose2Block] = rig.mirror2_pose.data();
  b[kReflexBlock] = rig.reflex.data();
  b[kProfile1Block] = rig.mirror1_profile.data();
  b[kProfile2Block] = rig.mirror2_profile.data();
  return b;
}

ProfileShape DefaultProfileShape(const RigParams& rig, Mirror mirror) {
  ProfileShape shape;
  shape.present = true;
  shape.r_min = mirror == Mirror::kOne && !rig.Single() ? rig.r_ref : rig.r_cam;
  shape.r_max = rig.r_sys;
  return shape;
}

}  // namespace omni
