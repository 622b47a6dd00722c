#include "model/single_rim.h"

#include <algorithm>
#include <cmath>

#include "model/lip.h"
#include "model/rig_frames.h"

namespace omni {

bool RimEdgeIsTheRim(const RigModel& model, double* elevation_deg) {
  const RigParams& rig = model.params();
  if (!rig.Single()) return false;
  const RigBlocks<double> blocks = RigBlocksOf(rig);
  const Eigen::Vector3d axis_in_cam =
      PoseFromBlock(rig.mirror1_pose.data()).Rotate(Eigen::Vector3d::UnitZ());
  const Eigen::Vector2d principal(rig.camera[kCx], rig.camera[kCy]);
  // One pixel inside the rim's image at 16 azimuths: the reflected ray's elevation from the
  // rim's plane (the axis points from the vertex to the rim: away from the camera).
  double steepest = -90;
  int traced = 0;
  for (int k = 0; k < 16; ++k) {
    Eigen::Vector2d rim_px;
    if (!ProjectLipPoint(blocks, model.fixed(), LipPath::kDirect, rig.r_sys, SingleRimZ(rig),
                         2 * M_PI * (k + 0.5) / 16, &rim_px)) {
      continue;
    }
    const Eigen::Vector2d inside = rim_px - (rim_px - principal).normalized();
    const auto ray = model.Unproject(inside);
    if (!ray) continue;
    const double sine = std::clamp(ray->ray.direction.normalized().dot(axis_in_cam), -1.0, 1.0);
    steepest = std::max(steepest, std::asin(sine) * 180 / M_PI);
    ++traced;
  }
  if (elevation_deg) *elevation_deg = steepest;
  // A fraction of a degree past the plane: a thin holder at the rim is seen edge on.
  return traced >= 8 && steepest <= 0.5;
}

}  // namespace omni
