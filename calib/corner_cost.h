// Reprojection residuals of target corners through each mirror's optical path. The projection is
// model/rig_model.h's ProjectViaMirror1/2 over the raw parameter blocks (the same templated code
// every other caller runs), so Ceres differentiates exactly the model that is written out.
//
// Target pose block cam_from_target[6]: angle-axis rotation (3), translation in mm (3);
// point_in_cam = R(w) * corner_in_target + t. A rotation vector is minimal (no manifold needed)
// and regular for every rotation angle below pi.
#pragma once

#include <ceres/jet.h>
#include <ceres/rotation.h>
#include <ceres/sized_cost_function.h>

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

// The pixel residual of a point in C through mirror 1 (outer ring): blocks camera, distortion,
// mirror1_shape, mirror1_profile, mirror1_pose, reflex, point_in_cam (3). The reflex block only
// decides validity on this path (the disc's occlusion): no derivative. The profile block is read
// only where fixed.profile1 is present.
struct Mirror1PointResidual {
  Eigen::Vector2d observed;
  RigFixed fixed;
  static constexpr uint32_t kNoDerivative[7] = {0, 0, 0, 0, 0, 0b111, 0};

  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* mirror1_shape,
                  const T* mirror1_profile, const T* mirror1_pose, const T* reflex,
                  const T* point_in_cam, T* residual) const {
    Vec2<T> pixel;
    const RigBlocks<T> blocks{camera,  distortion, mirror1_shape,   mirror1_pose,
                              reflex,  nullptr,    nullptr,         mirror1_profile,
                              nullptr};
    if (!ProjectViaMirror1(blocks, fixed,
                           Vec3<T>(point_in_cam[0], point_in_cam[1], point_in_cam[2]), &pixel)) {
      return false;
    }
    residual[0] = pixel.x() - T(observed.x());
    residual[1] = pixel.y() - T(observed.y());
    return true;
  }
};

// Through mirror 2 and the reflex disc (inner ring): blocks camera, distortion, mirror1_pose,
// reflex, mirror2_shape, mirror2_profile, mirror2_pose, point_in_cam (3) (the reflex disc is part
// of mirror 1's body, so mirror 1's pose moves it).
struct Mirror2PointResidual {
  Eigen::Vector2d observed;
  RigFixed fixed;
  static constexpr uint32_t kNoDerivative[8] = {0, 0, 0, 0, 0, 0, 0, 0};

  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* mirror1_pose, const T* reflex,
                  const T* mirror2_shape, const T* mirror2_profile, const T* mirror2_pose,
                  const T* point_in_cam, T* residual) const {
    Vec2<T> pixel;
    const RigBlocks<T> blocks{camera,        distortion,   nullptr, mirror1_pose,   reflex,
                              mirror2_shape, mirror2_pose, nullptr, mirror2_profile};
    if (!ProjectViaMirror2(blocks, fixed,
                           Vec3<T>(point_in_cam[0], point_in_cam[1], point_in_cam[2]), &pixel)) {
      return false;
    }
    residual[0] = pixel.x() - T(observed.x());
    residual[1] = pixel.y() - T(observed.y());
    return true;
  }
};

// A corner's residual over the rig blocks and its target pose cam_from_target (6): the point
// residual at point_in_cam = CornerInCam(pose), differentiated with 3 Jet slots for the point
// instead of 6 for the pose (the chain rule with d point / d pose, a 3 x 6 Jacobian in double).
// held_camera / held_distortion: see calib/slot_autodiff.h.
template <typename PointResidual, int... kRigBlockSizes>
class CornerCostFunction final : public ceres::SizedCostFunction<2, kRigBlockSizes..., 6> {
 public:
  static constexpr int kNumRig = sizeof...(kRigBlockSizes);
  using Inner = SlotAutoDiffCostFunction<PointResidual, 2, kRigBlockSizes..., 3>;

  CornerCostFunction(const PointResidual& residual, const Eigen::Vector3d& corner_in_target,
                     const uint32_t* held_camera, const uint32_t* held_distortion)
      : inner_(residual, Masks(), HeldMasks(held_camera, held_distortion)),
        corner_in_target_(corner_in_target) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* pose = parameters[kNumRig];
    double point[3];
    double point_from_pose[3 * 6];  // d point_in_cam / d cam_from_target, row-major
    const bool want_pose = jacobians && jacobians[kNumRig];
    if (want_pose) {
      using Jet6 = ceres::Jet<double, 6>;
      Jet6 pose_jet[6];
      for (int k = 0; k < 6; ++k) pose_jet[k] = Jet6(pose[k], k);
      const Vec3<Jet6> p = CornerInCam(pose_jet, corner_in_target_);
      for (int r = 0; r < 3; ++r) {
        point[r] = p[r].a;
        for (int k = 0; k < 6; ++k) point_from_pose[r * 6 + k] = p[r].v[k];
      }
    } else {
      const Vec3<double> p = CornerInCam(pose, corner_in_target_);
      for (int r = 0; r < 3; ++r) point[r] = p[r];
    }
    const double* inner_parameters[kNumRig + 1];
    double* inner_jacobians[kNumRig + 1];
    double residual_from_point[2 * 3];
    for (int i = 0; i < kNumRig; ++i) {
      inner_parameters[i] = parameters[i];
      inner_jacobians[i] = jacobians ? jacobians[i] : nullptr;
    }
    inner_parameters[kNumRig] = point;
    inner_jacobians[kNumRig] = want_pose ? residual_from_point : nullptr;
    if (!inner_.Evaluate(inner_parameters, residuals, jacobians ? inner_jacobians : nullptr)) {
      return false;
    }
    if (want_pose) {
      for (int r = 0; r < 2; ++r) {
        for (int k = 0; k < 6; ++k) {
          double sum = 0;
          for (int m = 0; m < 3; ++m) sum += residual_from_point[r * 3 + m] * point_from_pose[m * 6 + k];
          jacobians[kNumRig][r * 6 + k] = sum;
        }
      }
    }
    return true;
  }

 private:
  static typename Inner::Masks Masks() {
    typename Inner::Masks m{};
    for (int i = 0; i < kNumRig; ++i) m[i] = PointResidual::kNoDerivative[i];
    return m;
  }
  static typename Inner::HeldMasks HeldMasks(const uint32_t* camera, const uint32_t* distortion) {
    typename Inner::HeldMasks h{};
    h[0] = camera;  // blocks 0 and 1 of every corner residual
    h[1] = distortion;
    return h;
  }

  Inner inner_;
  Eigen::Vector3d corner_in_target_;
};

// The corner residuals over the target pose (the definition; Create gives the fast
// CornerCostFunction of the same value and derivatives, tests/calib/slot_autodiff_test.cc).
// Outer ring: blocks camera, distortion, mirror1_shape, mirror1_profile, mirror1_pose, reflex,
// cam_from_target.
struct Mirror1CornerCost {
  Eigen::Vector2d observed;
  Eigen::Vector3d corner_in_target;
  RigFixed fixed;

  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* mirror1_shape,
                  const T* mirror1_profile, const T* mirror1_pose, const T* reflex,
                  const T* cam_from_target, T* residual) const {
    const Vec3<T> point = CornerInCam(cam_from_target, corner_in_target);
    return Mirror1PointResidual{observed, fixed}(camera, distortion, mirror1_shape,
                                                 mirror1_profile, mirror1_pose, reflex,
                                                 point.data(), residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& corner_in_target,
                                     const RigFixed& fixed,
                                     const uint32_t* held_camera = nullptr,
                                     const uint32_t* held_distortion = nullptr) {
    return new CornerCostFunction<Mirror1PointResidual, 5, 5, 2, kProfileTerms, 5, 3>(
        Mirror1PointResidual{observed, fixed}, corner_in_target, held_camera, held_distortion);
  }
};

// Inner ring: blocks camera, distortion, mirror1_pose, reflex, mirror2_shape, mirror2_profile,
// mirror2_pose, cam_from_target.
struct Mirror2CornerCost {
  Eigen::Vector2d observed;
  Eigen::Vector3d corner_in_target;
  RigFixed fixed;

  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* mirror1_pose, const T* reflex,
                  const T* mirror2_shape, const T* mirror2_profile, const T* mirror2_pose,
                  const T* cam_from_target, T* residual) const {
    const Vec3<T> point = CornerInCam(cam_from_target, corner_in_target);
    return Mirror2PointResidual{observed, fixed}(camera, distortion, mirror1_pose, reflex,
                                                 mirror2_shape, mirror2_profile, mirror2_pose,
                                                 point.data(), residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& corner_in_target,
                                     const RigFixed& fixed,
                                     const uint32_t* held_camera = nullptr,
                                     const uint32_t* held_distortion = nullptr) {
    return new CornerCostFunction<Mirror2PointResidual, 5, 5, 5, 3, 2, kProfileTerms, 5>(
        Mirror2PointResidual{observed, fixed}, corner_in_target, held_camera, held_distortion);
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
