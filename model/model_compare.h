// How far apart two rig models put the same 3D points in the image: the figure that says what a
// calibration gains (calibrated vs true model, or nominal vs true model).
#pragma once

#include <vector>

#include "model/rig_model.h"

namespace omni {

struct ProjectionDifference {
  int points = 0;                 // points the reference sees in both rings (the stereo band)
  double rms_px[2] = {0, 0};      // per ring [mirror 1, mirror 2], over points both models see
  double max_px[2] = {0, 0};
  int lost = 0;                   // (point, ring) pairs the compared model does not project
};

// Points on the cylinder of horizontal radius `range_mm` about the camera axis (72 azimuths,
// heights every range/40 within +-1.5 range) that `model` sees in both rings (the stereo band).
// A single-mirror rig has one ring and no stereo: its band is what that ring sees, and pixel[1]
// is NaN (loop over the rings as model.params().Paths()).
struct BandPoint {
  Eigen::Vector3d point_in_cam;
  Eigen::Vector2d pixel[2];  // via mirror 1, mirror 2
};
std::vector<BandPoint> StereoBandPoints(const RigModel& model, double range_mm);

// Points on the cylinder of horizontal radius `range_mm` about the camera axis (72 azimuths,
// heights every range/40), kept where `reference` sees them in both rings; each is projected by
// both models through each mirror.
ProjectionDifference CompareProjections(const RigModel& reference, const RigModel& other,
                                        double range_mm);

// The same after removing the best rotation of the camera frame: `other` projects R * p where
// reference projects p, with R (the rotation vector `rotation_rad`, least squares over both rings'
// pixels) found by Gauss-Newton. Why: the camera's rotation against the mirror bodies is only
// weakly determined by a calibration (it trades with the principal point and equal tilts of both
// mirrors), and it rotates every measured point rigidly, changing no distance or shape; this
// figure is the model error that 3D measurement sees, the plain one adds the frame's pointing.
ProjectionDifference CompareProjectionsUpToRotation(const RigModel& reference,
                                                    const RigModel& other, double range_mm,
                                                    Eigen::Vector3d* rotation_rad = nullptr);

// The same with the points fixed in mirror 1's body M1 instead of in the camera frame: `other`
// projects other.cam_from_mirror1 * reference.mirror1_from_cam * p where reference projects p.
// Why: M1 (mirror 1 with the reflex disc) is the rig's physical reference, the frame
// `triangulate --frame mirror1` reports in; C's pointing against the mirror bodies is what a lens
// with unknown decentring distortion (dist_p1, dist_p2, held by the calibration) leaves open.
// Unlike CompareProjectionsUpToRotation nothing is fitted to the reference here.
// (A single mirror's points are held against its vertex: RigParams::vertex_z is each model's own
// convention.)
ProjectionDifference CompareProjectionsInMirror1(const RigModel& reference, const RigModel& other,
                                                 double range_mm);

}  // namespace omni
