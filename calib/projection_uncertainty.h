// What a calibration's uncertainty means where a user measures (docs/design.md, Conventions): the
// covariance of the rig parameters propagated to the pixels of points at a given range, held in
// mirror 1's body M1 (the rig's physical frame, `triangulate --frame mirror1`) or in the camera
// frame C, over the stereo band (model/model_compare.h's points). The same figure as
// CompareProjectionsInMirror1 / CompareProjections against the true rig, predicted: on a
// synthetic session the measured difference should be about this (its RMS over noise draws is
// the prediction), and with the truth the parameter error's share of it per parameter group
// says which parameters carry a difference.
#pragma once

#include <string>
#include <vector>

#include "calib/calibrate.h"

namespace omni::calib {

struct ProjectionUncertainty {
  // Predicted RMS of the projection difference from the true rig (sqrt of the mean over the band
  // of trace(J C J^T)), per ring [mirror 1, mirror 2].
  double in_mirror1_px[2] = {0, 0};
  double in_cam_px[2] = {0, 0};
  int points = 0;
};

// The linearised projection difference of `result.estimate.rig` from `truth` (parameter error
// value - truth over the refined parameters), points held in M1: per ring, in total and with
// only one parameter group's error (camera, distortion, mirror1, mirror2, reflex), plus the
// Mahalanobis distance of the whole error (chi^2 with result.estimate.names.size() degrees of
// freedom).
struct ProjectionErrorShare {
  double total_px[2] = {0, 0};
  std::vector<std::string> groups;
  std::vector<std::array<double, 2>> group_px;
  double chi2 = 0;
  int dof = 0;
};

ProjectionUncertainty PredictProjectionUncertainty(const CalibrationResult& result,
                                                   double range_mm);

// The same per point of the stereo band at range_mm (every 4th of model_compare.h's points that
// every perturbed model projects): the predicted sigma of its pixel, sqrt(trace(J C J^T)) (the
// RMS distance from the true pixel over draws of the calibration), per ring, the point held in
// M1 or in C. PredictProjectionUncertainty is the RMS of these over the points.
struct PointUncertainty {
  Eigen::Vector3d point_in_cam = Eigen::Vector3d::Zero();
  Eigen::Vector2d pixel[2];  // via mirror 1, mirror 2 (at the calibrated model)
  double in_mirror1_px[2] = {0, 0};
  double in_cam_px[2] = {0, 0};
  // From the pixel noise alone (CalibrationUncertainty::noise_sigma's share, without the considered
  // parameters'): what repeating the session with fresh noise would scatter.
  double noise_in_mirror1_px[2] = {0, 0};
  double noise_in_cam_px[2] = {0, 0};
};
std::vector<PointUncertainty> ProjectionUncertaintyMap(const CalibrationResult& result,
                                                       double range_mm);
// The RMS over a map's points (PredictProjectionUncertainty of the map's result and range).
ProjectionUncertainty RmsOf(const std::vector<PointUncertainty>& map);

ProjectionErrorShare ShareOfProjectionError(const CalibrationResult& result,
                                            const RigParams& truth, double range_mm);

}  // namespace omni::calib
