#include "model/ideal_model.h"

namespace omni {

std::optional<IdealRay> Unproject(const IdealModel& model, const Eigen::Vector2d& pixel) {
  const Mirror mirror = model.MirrorOfPixel(pixel);
  Eigen::Vector3d point_on_mirror, dir;
  if (!model.BackProject(pixel, mirror, &point_on_mirror, &dir)) return std::nullopt;
  IdealRay out;
  out.mirror = mirror;
  out.ray.origin = mirror == Mirror::kOne ? model.Focus1() : model.Focus2();
  out.ray.direction = dir.normalized();
  return out;
}

IdealModel MakeIdealModel(const DesignParams& theta, double r_cam, const Pinhole<double>& cam) {
  IdealModel m{theta.c1, theta.c2, theta.k1, theta.k2, theta.d, theta.r_sys, 0.0, r_cam, cam};
  double r_ref = 0;
  // Where mirror 1 meets the reflex plane z = d/2; 0 if the plane misses the sheet.
  if (!m.Mirror1().R(theta.d / 2, &r_ref)) r_ref = 0;
  m.r_ref = r_ref;
  return m;
}

}  // namespace omni
