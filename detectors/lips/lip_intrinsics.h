// An initial focal length and principal point from detected lip edges: the way the paper's
// authors initialised their real camera (the lips' known 3D radii and heights fix the scale).
//
// Fits fx = fy = f, cx, cy (skew 0; distortion, mirror poses and reflex plane held at the given
// model's values) so that every labelled edge point lies on the image of its 3D lip circle along
// its optical path (model/lip.h): one azimuth per point is estimated with the intrinsics (Ceres).
//
// What lips cannot tell: a common tilt of a mirror body about the camera centre moves its lip
// images like a principal-point shift (f * tilt * sec^2(angle off the axis); the difference
// between the lips' angles off the axis is a few per cent), so with a nominal (ideal) model the
// principal point absorbs the mirrors' tilts: about f * tilt pixels (1450 px * 0.005 rad ~ 7 px on
// the misaligned sample rig). The focal length is well determined (lip size).
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "model/observations.h"
#include "model/rig_model.h"

namespace omni::detectors {

struct LipIntrinsics {
  double f = 0, cx = 0, cy = 0;
  double sigma_f = 0, sigma_cx = 0, sigma_cy = 0;  // from the residual spread (px), 1 sigma
  double rms_px = 0;  // point-to-circle-image residual
  // With fit_reflex_tilt: the reflex plane's rx, ry (rad, mirror 1's body frame). It stands for
  // every tilt that moves the inner ring against the outer (mirror 2's, the reflex's).
  std::optional<Eigen::Vector2d> reflex_tilt;
  // With fit_reflex_tilt: mirror 2's axial offset tz (mm, within 5 mm of the model's). It stands
  // for every misalignment that scales the inner ring's image against the outer (the
  // via_mirror2 edge's radius), not for mirror 2's true offset.
  std::optional<double> mirror2_tz;
  int n_points = 0;
};

// nullopt if fewer than 20 usable labelled points or the solve fails. Edges without a known
// circle/path label are ignored.
// fit_reflex_tilt: also the reflex plane's tilt and mirror 2's axial offset, where 20 or more
// via_mirror2 points were found (the lip guide, lip_guide.h: the inner ring's images move and
// scale with them).
std::optional<LipIntrinsics> InitialIntrinsicsFromLips(const std::vector<LipEdgeObservation>& edges,
                                                       const RigModel& nominal,
                                                       bool fit_reflex_tilt = false);
// The same over every image's lip edges (init's start, detect's lips-only check).
std::optional<LipIntrinsics> InitialIntrinsicsFromLipsOf(const Observations& detections,
                                                         const RigModel& nominal);

// Where a rig's mirror bodies put the points a lip-only fit can find instead of the principal
// point (for evaluation against a true rig): the vanishing points K * R_cam_from_mirror_i *
// (0, 0, 1) of the mirror axes, lip 1's centre seen directly, and lip 2's centre and mirror 2's
// axis direction seen in the reflex plane. Distortion-free pinhole pixels: these points lie
// within ~0.02 (normalised) of the optical axis, where the lens moves them < 0.01 px.
struct LipReferencePoints {
  Eigen::Vector2d axis1, axis2, lip1_centre, lip2_centre_in_reflex, axis2_in_reflex;
};
LipReferencePoints LipReferencePointsOf(const RigParams& rig);

}  // namespace omni::detectors
