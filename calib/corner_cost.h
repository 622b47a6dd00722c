// Reprojection residuals of target corners through each mirror's optical path. The projection is
// model/rig_model.h's ProjectViaMirror1/2 over the raw parameter blocks (the same templated code
// every other caller runs), so Ceres differentiates exactly the model that is written out.
//
// Target pose block cam_from_target[6]: angle-axis rotation (3), translation in mm (3);
// point_in_cam = R(w) * corner_in_target + t. A rotation vector is minimal (no manifold needed)
// and regular for every rotation angle below pi.
#pragma once

#include <ceres/rotation.h>

#include <cstdint>

#include <Eigen/Core>

#include "calib/slot_autodiff.h"
#include "model/rig_model.h"

namespace omni::calib {

template <typename T>
Vec3<T> CornerInCam(const T* cam_from_target, const Eigen::Vector3d& corner_in_target) {
  const T corner[3] = {T(corner_in_target.x()), T(corner_in_target.y()), T(corner_in_target.z())};
  T rotated[3];
  ceres::AngleAxisRotatePoint(cam_from_target, corner, rotated);
  return Vec3<T>(rotated[0] + cam_from_target[3], rotated[1] + cam_from_target[4],
                 rotated[2] + cam_from_target[5]);
}

// Outer ring: blocks camera, distortion, mirror1_shape, mirror1_pose, reflex, cam_from_target.
// The reflex block only decides validity on this path (the disc's occlusion): no derivative.
// held_camera / held_distortion (optional): masks of the coordinates the solver holds, read at
// each evaluation (calib/slot_autodiff.h).
struct Mirror1CornerCost {
  Eigen::Vector2d observed;
  Eigen::Vector3d corner_in_target;
  RigFixed fixed;

  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* mirror1_shape,
                  const T* mirror1_pose, const T* reflex, const T* cam_from_target,
                  T* residual) const {
    Vec2<T> pixel;
    if (!ProjectViaMirror1(camera, distortion, mirror1_shape, mirror1_pose, reflex, fixed,
                           CornerInCam(cam_from_target, corner_in_target), &pixel)) {
      return false;
    }
    residual[0] = pixel.x() - T(observed.x());
    residual[1] = pixel.y() - T(observed.y());
    return true;
  }

  using CostFunction = SlotAutoDiffCostFunction<Mirror1CornerCost, 2, 5, 5, 2, 5, 3, 6>;
  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& corner_in_target,
                                     const RigFixed& fixed,
                                     const uint32_t* held_camera = nullptr,
                                     const uint32_t* held_distortion = nullptr) {
    return new CostFunction(Mirror1CornerCost{observed, corner_in_target, fixed},
                            {0, 0, 0, 0, 0b111, 0},
                            {held_camera, held_distortion, nullptr, nullptr, nullptr, nullptr});
  }
};

// Inner ring: blocks camera, distortion, mirror1_pose, reflex, mirror2_shape, mirror2_pose,
// cam_from_target (the reflex disc is part of mirror 1's body, so mirror 1's pose moves it).
struct Mirror2CornerCost {
  Eigen::Vector2d observed;
  Eigen::Vector3d corner_in_target;
  RigFixed fixed;

  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* mirror1_pose, const T* reflex,
                  const T* mirror2_shape, const T* mirror2_pose, const T* cam_from_target,
                  T* residual) const {
    Vec2<T> pixel;
    if (!ProjectViaMirror2(camera, distortion, mirror1_pose, reflex, mirror2_shape, mirror2_pose,
                           fixed, CornerInCam(cam_from_target, corner_in_target), &pixel)) {
      return false;
    }
    residual[0] = pixel.x() - T(observed.x());
    residual[1] = pixel.y() - T(observed.y());
    return true;
  }

  using CostFunction = SlotAutoDiffCostFunction<Mirror2CornerCost, 2, 5, 5, 5, 3, 2, 5, 6>;
  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& corner_in_target,
                                     const RigFixed& fixed,
                                     const uint32_t* held_camera = nullptr,
                                     const uint32_t* held_distortion = nullptr) {
    return new CostFunction(
        Mirror2CornerCost{observed, corner_in_target, fixed}, {0, 0, 0, 0, 0, 0, 0},
        {held_camera, held_distortion, nullptr, nullptr, nullptr, nullptr, nullptr});
  }
};

// Gaussian prior on one coordinate of a block: (x - mean) / sigma.
struct ScalarPriorCost {
  int index;
  double mean, sigma;

  template <typename T>
  bool operator()(const T* block, T* residual) const {
    residual[0] = (block[index] - T(mean)) / T(sigma);
    return true;
  }
};

}  // namespace omni::calib
