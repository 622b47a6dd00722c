// What a single-mirror camera's calibration says in its own terms (rig: single): the mirror's
// conic, how far the camera sits from the point that would make it central (a perspective
// lens: the mirror's far focus; a telecentric lens: its axis along the lens's), each with its
// sigma propagated from the covariance, and what the photos leave open (the mirror's absolute
// size when nothing measured fixes it; any coordinate named unobservable).
#pragma once

#include <string>

#include <Eigen/Core>

#include "calib/calibrate.h"

namespace omni::calib {

struct SingleMirrorSummary {
  std::string mirror;          // "paraboloid", "hyperboloid", ...
  double R = 0, K = 0, sigma_R = 0, sigma_K = 0;  // sigma 0: held; NaN: unobservable
  // Perspective: the camera's centre minus the mirror's far focus, in the mirror's frame M1
  // (z along its axis), mm; the mirror has no far focus (paraboloid, sphere): has_offset false.
  bool has_offset = false;
  Eigen::Vector3d offset_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d offset_sigma_mm = Eigen::Vector3d::Zero();  // NaN where unobservable
  // The mirror's axis against the camera's (rad) and its sigma.
  double axis_tilt_rad = 0, axis_tilt_sigma_rad = 0;
  std::vector<std::string> open;  // what the photos leave open, in words
  // The non-central part was tested and not decided (NonCentralDecision): the pose above is held
  // at the start's (central), and this is the non-central fit's offset and tilt with their
  // sigmas (has_fit false where that solve failed: `fit_failure`).
  bool central_kept = false, has_fit = false;
  std::string fit_failure;
  double fit_axis_tilt_rad = 0, fit_axis_tilt_sigma_rad = 0;
  bool fit_has_offset = false;
  Eigen::Vector3d fit_offset_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d fit_offset_sigma_mm = Eigen::Vector3d::Zero();
};

// From a calibration of a single-mirror rig (result.estimate.rig.Single()).
SingleMirrorSummary SummariseSingleMirror(const CalibrationResult& result);

// Its lines for the CLI and the report.
std::string SingleMirrorText(const SingleMirrorSummary& summary);

}  // namespace omni::calib
