// Residuals of lip edge points (model/lip.h, detectors/lips/lip_detector.h): an edge point is the image
// of some point on a known 3D circle (a lip's r_inner or r_outer circle in its mirror's body
// frame) along a known optical path, at an unknown azimuth phi. Each edge point gets its own phi
// (a 1-parameter nuisance block, eliminated like a target pose), and the residual is the pixel of
// that circle point along the path minus the observed pixel, weighted like a corner. Per point
// this adds 2 residuals and 1 unknown: the component across the edge constrains the rig.
//
// The curve is the band's edge with the occlusion followed (ProjectLipEdge, model/lip.h): where
// the reflex disc's rim hides the lip circle a via_reflex point was labelled with, the residual
// is to the rim's image instead, decided anew at every evaluation (the detector labels edges on
// a model that may not know where the rim hides them; 190 of 410 points per image on a rig with
// a larger, tilted disc).
//
// The lips are what the target corners cannot give: the blue lip is seen straight by the camera
// (pinhole + distortion of a point at a known place in mirror 1's body, no mirror in between) and
// via mirror 1, the red lip via mirror 2; an edge at a known metric radius and height pins the
// focal length against distortion and the mirrors' heights (tz).
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "calib/slot_autodiff.h"
#include "model/lip.h"

namespace omni::calib {

// Blocks: camera, distortion, mirror1_shape, mirror1_pose, reflex, mirror2_shape, mirror2_pose,
// mirror1_profile, mirror2_profile, phi (1). Each path uses only some of them (NoDerivative); held_camera / held_distortion as in
// corner_cost.h.
struct LipPointCost {
  Eigen::Vector2d observed;
  LipPath path;
  double radius, lip_z;  // the circle in its mirror's body frame (mm)
  RigFixed fixed;
  double disc_radius_mm = 0;  // the reflex disc's rim that clips via_reflex bands (0: none)

  template <typename T>
  bool operator()(const T* camera, const T* distortion, const T* mirror1_shape,
                  const T* mirror1_pose, const T* reflex, const T* mirror2_shape,
                  const T* mirror2_pose, const T* mirror1_profile, const T* mirror2_profile,
                  const T* phi, T* residual) const {
    const RigBlocks<T> blocks{camera,        distortion,   mirror1_shape,   mirror1_pose,
                              reflex,        mirror2_shape, mirror2_pose,   mirror1_profile,
                              mirror2_profile};
    return LipEdgeResidual(blocks, fixed, path, T(radius), T(lip_z), phi[0], disc_radius_mm,
                           observed, residual);
  }

  using CostFunction = SlotAutoDiffCostFunction<LipPointCost, 2, 5, 5, 2, 5, 3, 2, 5,
                                                kProfileTerms, kProfileTerms, 1>;

  // The blocks a path's pixel does not depend on differentiably: unused ones, and the reflex
  // plane where it only decides validity (direct: the disc's back; via_mirror1: its occlusion).
  static std::array<uint32_t, 10> NoDerivative(LipPath path) {
    constexpr uint32_t kAll = 0b111111;
    switch (path) {
      case LipPath::kDirect:  // camera, distortion, mirror1_pose (the lip's place)
        return {0, 0, kAll, 0, kAll, kAll, kAll, kAll, kAll, 0};
      case LipPath::kViaMirror1:  // + mirror1_shape, mirror1_profile
        return {0, 0, 0, 0, kAll, kAll, kAll, 0, kAll, 0};
      case LipPath::kViaReflex:  // camera, distortion, mirror1_pose + reflex (the plane), mirror2_pose
        return {0, 0, kAll, 0, 0, kAll, 0, kAll, kAll, 0};
      case LipPath::kViaMirror2:
        return {0, 0, kAll, 0, 0, 0, 0, kAll, 0, 0};
    }
    return {};
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed, LipPath path, double radius,
                                     double lip_z, const RigFixed& fixed,
                                     const uint32_t* held_camera = nullptr,
                                     const uint32_t* held_distortion = nullptr,
                                     double disc_radius_mm = 0) {
    return new CostFunction(
        LipPointCost{observed, path, radius, lip_z, fixed, disc_radius_mm}, NoDerivative(path),
        {held_camera, held_distortion, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr,
         nullptr, nullptr});
  }
};

}  // namespace omni::calib
