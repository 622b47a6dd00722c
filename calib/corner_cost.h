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

#include <array>
#include <cstdint>
#include <memory>
#include <utility>

#include <Eigen/Core>

#include "calib/rig_cost.h"
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

// The residual of a pixel: projected minus observed.
template <typename T>
bool PixelResidual(bool valid, const Vec2<T>& pixel, const Eigen::Vector2d& observed, T* residual) {
  if (!valid) return false;
  residual[0] = pixel.x() - T(observed.x());
  residual[1] = pixel.y() - T(observed.y());
  return true;
}

// The pixel residual of a point in C through mirror 1 (outer ring): over the rig blocks kBlocks
// (in that order), then point_in_cam (3). The reflex block only decides validity on this path
// (the disc's occlusion): no derivative. The profile block is read only where the fixed data's
// profile1 is present.
struct Mirror1PointResidual {
  static constexpr std::array<RigBlockId, 6> kBlocks = {
      kCameraBlock, kDistortionBlock, kShape1Block, kProfile1Block, kPose1Block, kReflexBlock};
  static constexpr RigBlockSet kDifferentiable = BlockSetOf(
      {kCameraBlock, kDistortionBlock, kShape1Block, kProfile1Block, kPose1Block});
  Eigen::Vector2d observed;
  std::shared_ptr<const RigFixed> fixed;

  template <typename T>
  bool operator()(T const* const* blocks, T* residual) const {
    const T* point = blocks[kBlocks.size()];
    Vec2<T> pixel;
    const bool valid = ProjectViaMirror1(RigBlocks<T>(kBlocks, blocks), *fixed,
                                         Vec3<T>(point[0], point[1], point[2]), &pixel);
    return PixelResidual(valid, pixel, observed, residual);
  }
};

// Through mirror 2 and the reflex disc (inner ring): over kBlocks, then point_in_cam (3) (the
// reflex disc is part of mirror 1's body, so mirror 1's pose moves it).
struct Mirror2PointResidual {
  static constexpr std::array<RigBlockId, 7> kBlocks = {
      kCameraBlock, kDistortionBlock, kPose1Block,   kReflexBlock,
      kShape2Block, kProfile2Block,   kPose2Block};
  static constexpr RigBlockSet kDifferentiable =
      BlockSetOf({kCameraBlock, kDistortionBlock, kPose1Block, kReflexBlock, kShape2Block,
                  kProfile2Block, kPose2Block});
  Eigen::Vector2d observed;
  std::shared_ptr<const RigFixed> fixed;

  template <typename T>
  bool operator()(T const* const* blocks, T* residual) const {
    const T* point = blocks[kBlocks.size()];
    Vec2<T> pixel;
    const bool valid = ProjectViaMirror2(RigBlocks<T>(kBlocks, blocks), *fixed,
                                         Vec3<T>(point[0], point[1], point[2]), &pixel);
    return PixelResidual(valid, pixel, observed, residual);
  }
};

// A corner's residual over the rig blocks PointResidual::kBlocks and its target pose
// cam_from_target (6): the point residual at point_in_cam = CornerInCam(pose), differentiated
// with 3 Jet slots for the point instead of 6 for the pose (the chain rule with d point / d pose,
// a 3 x 6 Jacobian in double). `held`: the rig coordinates the solve it is built for holds
// (calib/slot_autodiff.h).
template <typename PointResidual,
          typename Seq = std::make_index_sequence<PointResidual::kBlocks.size()>>
class CornerCostFunction;
template <typename PointResidual, size_t... I>
class CornerCostFunction<PointResidual, std::index_sequence<I...>> final
    : public ceres::SizedCostFunction<2, kRigBlocks[PointResidual::kBlocks[I]].size..., 6> {
 public:
  static constexpr int kNumRig = sizeof...(I);
  using Inner = RigSlotCost<PointResidual, 2, 3>;

  CornerCostFunction(const PointResidual& residual, const Eigen::Vector3d& corner_in_target,
                     const BlockMasks& held)
      : inner_(residual,
               InListOrder<kNumRig + 1>(PointResidual::kBlocks,
                                        NoDerivativeOutside(PointResidual::kDifferentiable)),
               InListOrder<kNumRig + 1>(PointResidual::kBlocks, held)),
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
  Inner inner_;
  Eigen::Vector3d corner_in_target_;
};

// The corner residual over the rig blocks of PointResidual and the target pose (the definition,
// e.g. for ceres::DynamicAutoDiffCostFunction; Create gives the fast CornerCostFunction of the
// same value and derivatives, tests/calib/slot_autodiff_test.cc).
template <typename PointResidual>
struct TargetCornerCost {
  static constexpr auto kBlocks = PointResidual::kBlocks;  // then cam_from_target (6)
  Eigen::Vector2d observed;
  Eigen::Vector3d corner_in_target;
  std::shared_ptr<const RigFixed> fixed;

  template <typename T>
  bool operator()(T const* const* blocks, T* residual) const {
    const Vec3<T> point = CornerInCam(blocks[kBlocks.size()], corner_in_target);
    const T* with_point[kBlocks.size() + 1];
    for (size_t i = 0; i < kBlocks.size(); ++i) with_point[i] = blocks[i];
    with_point[kBlocks.size()] = point.data();
    return PointResidual{observed, fixed}(with_point, residual);
  }

  // `held`: see CornerCostFunction (none: every Jacobian column).
  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     const Eigen::Vector3d& corner_in_target,
                                     std::shared_ptr<const RigFixed> fixed,
                                     const BlockMasks& held = {}) {
    return new CornerCostFunction<PointResidual>(PointResidual{observed, std::move(fixed)},
                                                 corner_in_target, held);
  }
};
// Outer ring: camera, distortion, mirror1_shape, mirror1_profile, mirror1_pose, reflex,
// cam_from_target. Inner ring: camera, distortion, mirror1_pose, reflex, mirror2_shape,
// mirror2_profile, mirror2_pose, cam_from_target.
using Mirror1CornerCost = TargetCornerCost<Mirror1PointResidual>;
using Mirror2CornerCost = TargetCornerCost<Mirror2PointResidual>;

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

// One row of a whitened Gaussian prior on a whole block: row . (x - mean). With the rows of
// L^-1 (covariance = L L^T) the rows' squares sum to (x - mean)^T covariance^-1 (x - mean).
template <int kSize>
struct LinearPriorCost {
  std::array<double, kSize> row, mean;

  template <typename T>
  bool operator()(const T* block, T* residual) const {
    residual[0] = T(0);
    for (int j = 0; j < kSize; ++j) residual[0] += T(row[j]) * (block[j] - T(mean[j]));
    return true;
  }
};

}  // namespace omni::calib
