// Central approximations of the calibrated non-central rig, one per ring (a single-mirror rig: one), for the
// packages that only know central cameras (Kalibr, basalt, OpenVINS, VINS): each ring becomes a
// virtual central camera with its own pose in the rig frame and the unified (Kalibr omni+radtan)
// or double-sphere (basalt ds) intrinsics (central_models.h), fitted by least squares in pixels
// to the non-central model over the ring.
//
// The fit: pixels on a grid (every fit_step_px) of the ring, each back-projected by the
// non-central model (RigModel::Unproject) and the points at fit_distances_mm along its ray
// projected by the central model; the squared pixel differences are minimised over the
// intrinsics and the virtual camera's pose (Ceres). The start: the viewpoint at the ring's
// focus (stereo/panorama.h), z along the mirror axis (towards the directions whose pixels
// lie inward), x turned so that azimuth matches the pixel's polar angle; a ring whose azimuth
// runs against the polar angle (one reflection more or fewer than the other) gets fy < 0.
// The double sphere starts from the unified fit (xi = 0 is the unified model with
// alpha = xi_u / (1 + xi_u), f = f_u / (1 + xi_u)).
//
// What the approximation costs: the same residual on a finer grid (report_step_px) at each of
// report_distances_mm, RMS and max per ring, and a per-pixel map at map_distance_mm. A central
// model cannot be exact for a non-central ring: the error grows as points come nearer.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_frames.h"
#include "model/rig_model.h"
#include "model/triangulation.h"

namespace omni::exports {

enum class CentralModel { kUnified, kDoubleSphere };
const char* CentralModelName(CentralModel model);  // "unified (omni + radtan)" | "double sphere"

struct CentralFitOptions {
  ReferenceBody frame = ReferenceBody::kCam;  // the rig frame the virtual cameras are posed in
  int fit_step_px = 8;
  int report_step_px = 4;
  std::vector<double> fit_distances_mm = {500, 1000, 2000, 4000, 8000};
  std::vector<double> report_distances_mm = {250, 1000, 8000};
  double map_distance_mm = 1000;
};

struct CentralResidual {
  double distance_mm = 0;
  double rms_px = 0, max_px = 0;
  int pixels = 0;        // grid pixels of the ring compared
  int not_projected = 0; // of those, points the central model cannot project
};

struct CentralRing {
  Mirror mirror = Mirror::kOne;
  CentralModel model = CentralModel::kUnified;
  // Unified: xi, fu, fv, cu, cv, k1, k2, p1, p2; double sphere: fx, fy, cx, cy, xi, alpha.
  std::vector<double> intrinsics;
  Pose<double> cam_from_rig;  // the virtual camera from the rig frame (mm)
  std::vector<CentralResidual> residuals;  // one per report distance
  cv::Mat residual_map;  // CV_32F, the image's size: px at map_distance_mm; NaN off the grid/ring
  int iterations = 0;
  double fit_rms_px = 0;  // over the fit's samples
};

// The central approximation of each of `model`'s rings ([0]: mirror 1, [1]: mirror 2; a
// single-mirror rig's one ring alone).
std::vector<CentralRing> FitCentral(const RigModel& model, CentralModel kind,
                                      const CentralFitOptions& options);

}  // namespace omni::exports
