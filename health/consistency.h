// What a stored model says about one image of the natural scene (the in-field check):
// how far each ring-to-ring match and each lip edge point lies from where the model puts it.
// Both are signed, so a rig that moved shows as a pattern over the azimuth, not as noise.
#pragma once

#include <optional>

#include <Eigen/Core>

#include "model/observations.h"
#include "model/rig_model.h"

namespace omni::health {

// The gap between a match's two rays, in ring-2 pixels: the signed distance of pixel2 from the
// epipolar curve of pixel1 (the images via mirror 2 of the points of pixel1's mirror-1 ray, exact
// non-central model). The point on the ray is found by Gauss-Newton in its inverse range w
// (1/mm along the ray), started at *w if it is > 0 (else at the common perpendicular of both
// rays); *w receives the converged value. Sign: the curve's normal turned +90 deg from its
// direction of decreasing range, the same sense of azimuth all around the ring. nullopt if
// pixel1 does not see mirror 1, or the ray's points leave mirror 2's view.
std::optional<double> EpipolarGap(const RigModel& model, const Eigen::Vector2d& pixel1,
                                  const Eigen::Vector2d& pixel2, double* w = nullptr);

// A lip edge point's signed distance (px) across its edge's image under a model: positive away
// from the principal point.
struct LipPointResidual {
  LipPath path = LipPath::kDirect;
  LipCircle circle = LipCircle::kInner;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double phi = 0;                                    // azimuth on the circle of the nearest point
  Eigen::Vector2d normal = Eigen::Vector2d::Zero();  // unit, of the edge's image there
  double value = 0;
};

// nullopt where the model images no point of that circle along that path near the pixel.
std::optional<LipPointResidual> LipResidual(const RigModel& model, LipPath path,
                                            LipCircle circle, const Eigen::Vector2d& pixel);

// The same point's residual under another model, to first order: the circle point at the same
// phi, its image's move projected on the normal (what a small change of the parameters does to
// the distance; the slide along the edge is second order).
std::optional<double> LipResidualUnder(const RigModel& model, const LipPointResidual& at);

}  // namespace omni::health
