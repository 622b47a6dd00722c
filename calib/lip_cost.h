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
#include <memory>
#include <utility>

#include <Eigen/Core>

#include "calib/rig_cost.h"
#include "calib/slot_autodiff.h"
#include "model/conic.h"
#include "model/lip.h"

namespace omni::calib {

// Over the rig blocks kBlocks (every block: each path uses only some of them, the others get no
// derivative), then phi (1). `held` as in corner_cost.h.
struct LipPointCost {
  static constexpr std::array<RigBlockId, 9> kBlocks = {
      kCameraBlock, kDistortionBlock, kShape1Block,   kPose1Block,   kReflexBlock,
      kShape2Block, kPose2Block,      kProfile1Block, kProfile2Block};
  Eigen::Vector2d observed;
  LipPath path;
  double radius, lip_z;  // the circle in its mirror's body frame (mm)
  std::shared_ptr<const RigFixed> fixed;
  double disc_radius_mm = 0;  // the reflex disc's rim that clips via_reflex bands (0: none)

  template <typename T>
  bool operator()(T const* const* blocks, T* residual) const {
    const T* phi = blocks[kBlocks.size()];
    const RigBlocks<T> b(kBlocks, blocks);
    T z = T(lip_z);
    if (RimFollowsShape(*fixed, path)) {  // a single mirror's rim: the conic's own edge
      const T* shape = b[kShape1Block];
      z = T(fixed->vertex_z) + Conic<T>{shape[kShapeC], shape[kShapeK]}.Sag(T(radius * radius));
    }
    return LipEdgeResidual(b, *fixed, path, T(radius), z, phi[0], disc_radius_mm, observed,
                           residual);
  }

  // A single mirror's rim seen directly is the edge of the conic itself: its height above the
  // vertex is the sag at its radius, which moves with R and K (0.15 mm for a K 0.1 off on a 60 mm
  // hyperboloid: ~1 px), so it follows the refined shape. (The profile's few microns there are
  // left out.) A folded rig's lips are flat rings at fixed heights.
  static bool RimFollowsShape(const RigFixed& fixed, LipPath path) {
    return fixed.rig == RigKind::kSingle && path == LipPath::kDirect;
  }

  using CostFunction = RigSlotCost<LipPointCost, 2, 1>;

  // The blocks a path's pixel depends on differentiably: not the unused ones, nor the reflex
  // plane where it only decides validity (direct: the disc's back; via_mirror1: its occlusion).
  static RigBlockSet Differentiable(LipPath path, bool single = false) {
    switch (path) {
      case LipPath::kDirect:  // the lip's place (a single mirror's rim: and its height, the shape)
        return single ? BlockSetOf({kCameraBlock, kDistortionBlock, kPose1Block, kShape1Block})
                      : BlockSetOf({kCameraBlock, kDistortionBlock, kPose1Block});
      case LipPath::kViaMirror1:
        return BlockSetOf(
            {kCameraBlock, kDistortionBlock, kShape1Block, kPose1Block, kProfile1Block});
      case LipPath::kViaReflex:  // the plane, the lip's place
        return BlockSetOf(
            {kCameraBlock, kDistortionBlock, kPose1Block, kReflexBlock, kPose2Block});
      case LipPath::kViaMirror2:
        return BlockSetOf({kCameraBlock, kDistortionBlock, kPose1Block, kReflexBlock,
                           kShape2Block, kPose2Block, kProfile2Block});
    }
    return {};
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed, LipPath path, double radius,
                                     double lip_z, std::shared_ptr<const RigFixed> fixed,
                                     const BlockMasks& held = {}, double disc_radius_mm = 0) {
    constexpr size_t kAll = kBlocks.size() + 1;
    const bool single = fixed->rig == RigKind::kSingle;
    return new CostFunction(
        LipPointCost{observed, path, radius, lip_z, std::move(fixed), disc_radius_mm},
        InListOrder<kAll>(kBlocks, NoDerivativeOutside(Differentiable(path, single))),
        InListOrder<kAll>(kBlocks, held));
  }
};

// A single mirror's edge where it is not the rim (model/single_rim.h RimEdgeIsTheRim: the
// holder at the rim is seen in the mirror's outer zone): still the image of one circle on the
// mirror (the points whose reflected rays graze the holder's edge; fixed on the mirror, since the
// camera is), but of unknown radius. The radius is one more block, shared by every such point of
// the session; its height follows the conic (the sag at that radius). So the edge's centre and
// ellipse decide the mirror's decentre and tilt against the camera, while its size, spent on the
// radius, sets no scale (the rim's measured diameter is not used).
struct RimCirclePointCost {
  static constexpr auto kBlocks = LipPointCost::kBlocks;
  LipPointCost lip;  // its radius and lip_z unused: the radius block's

  template <typename T>
  bool operator()(T const* const* blocks, T* residual) const {
    const T* phi = blocks[kBlocks.size()];
    const T radius = blocks[kBlocks.size() + 1][0];
    const RigBlocks<T> b(kBlocks, blocks);
    const T* shape = b[kShape1Block];
    const T z = T(lip.fixed->vertex_z) +
                Conic<T>{shape[kShapeC], shape[kShapeK]}.Sag(radius * radius);
    return LipEdgeResidual(b, *lip.fixed, LipPath::kDirect, radius, z, phi[0],
                           lip.disc_radius_mm, lip.observed, residual);
  }

  using CostFunction = RigSlotCost<RimCirclePointCost, 2, 1, 1>;

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed,
                                     std::shared_ptr<const RigFixed> fixed,
                                     const BlockMasks& held = {}, double disc_radius_mm = 0) {
    constexpr size_t kAll = kBlocks.size() + 2;
    return new CostFunction(
        RimCirclePointCost{
            LipPointCost{observed, LipPath::kDirect, 0, 0, std::move(fixed), disc_radius_mm}},
        InListOrder<kAll>(kBlocks,
                          NoDerivativeOutside(LipPointCost::Differentiable(LipPath::kDirect, true))),
        InListOrder<kAll>(kBlocks, held));
  }
};

}  // namespace omni::calib
