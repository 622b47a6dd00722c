#include "pose/initial_pose.h"

#include <opencv2/calib3d.hpp>

#include <Eigen/Geometry>

#include "model/model_derived.h"
#include "model/rig_frames.h"

namespace omni {
namespace {

// The primary focus of a mirror in C (rig_frames.h).
Eigen::Vector3d FocusInCam(const RigParams& rig, Mirror mirror) {
  if (rig.Single()) return ComputeModelDerived(rig).focus1_in_cam;  // its near focus
  return mirror == Mirror::kOne
             ? Focus1InCam(rig.mirror1_pose.data(), rig.mirror1_shape.data())
             : Focus2InCam(rig.mirror2_pose.data(), rig.mirror2_shape.data(), rig.d);
}

}  // namespace

bool CentralPoseFromRing(const RigModel& start, Mirror mirror,
                         const std::vector<Eigen::Vector3d>& corners_in_target,
                         const std::vector<Eigen::Vector2d>& pixels, PoseGuess* pose) {
  std::vector<Eigen::Vector3d> rays;
  std::vector<cv::Point3d> object;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const auto ray = start.Unproject(pixels[i]);
    if (!ray || ray->mirror != mirror) continue;
    rays.push_back(ray->ray.direction.normalized());
    object.emplace_back(corners_in_target[i].x(), corners_in_target[i].y(),
                        corners_in_target[i].z());
  }
  if (rays.size() < 4) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& r : rays) mean += r;
  // virtual_from_cam turns the mean ray onto +z: the rays then fit a narrow-angle pinhole.
  const Eigen::Matrix3d virtual_from_cam =
      Eigen::Quaterniond::FromTwoVectors(mean.normalized(), Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  std::vector<cv::Point2d> normalized;
  for (const auto& r : rays) {
    const Eigen::Vector3d v = virtual_from_cam * r;
    if (!(v.z() > 1e-3)) return false;  // wider than a hemisphere: not one planar target
    normalized.emplace_back(v.x() / v.z(), v.y() / v.z());
  }
  cv::Mat rvec, tvec;
  const cv::Mat identity = cv::Mat::eye(3, 3, CV_64F);
  bool ok = false;
  try {
    ok = cv::solvePnP(object, normalized, identity, cv::Mat(), rvec, tvec, false,
                      cv::SOLVEPNP_IPPE);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) return false;
  cv::Mat rotation_cv;
  cv::Rodrigues(rvec, rotation_cv);
  Eigen::Matrix3d virtual_from_target;
  Eigen::Vector3d t_virtual;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) virtual_from_target(r, c) = rotation_cv.at<double>(r, c);
    t_virtual(r) = tvec.at<double>(r);
  }
  if (!(t_virtual.z() > 0) || !t_virtual.allFinite()) return false;
  // point_in_cam = F + cam_from_virtual * (R X + t).
  const Eigen::Matrix3d cam_from_target = virtual_from_cam.transpose() * virtual_from_target;
  const Eigen::AngleAxisd angle_axis(cam_from_target);
  pose->rotation = angle_axis.angle() * angle_axis.axis();
  pose->translation =
      FocusInCam(start.params(), mirror) + virtual_from_cam.transpose() * t_virtual;
  return true;
}

}  // namespace omni
