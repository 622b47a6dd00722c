// Sensitivity curves of the paper's section "Optimal Results": the effect of k on the system
// radius (fig. effect_of_k_on_system_radius), of k1 on the baseline (fig. effect_of_k1_on_baseline,
// [baseline_change_due_to_k]) and of k on the spatial resolution
// (fig. spatial_resolution_of_mirrors_for_various_k_values). Each curve is a table of rows that
// ToCsv() renders with a header; writing files is the caller's business (model/ does no I/O).
// Lengths mm, angles rad in the structs (the CSV columns say their unit).
#pragma once

#include <string>
#include <vector>

#include "model/ideal_model.h"

namespace omni::design {

// (a) r_sys vs k for several alpha_1. Mirror 1 with fixed c1 and fixed lower elevation
// theta_1,min: for each alpha_1 and k, theta_1,max = theta_1,min + alpha_1 and r_sys is the radius
// where the ray from F1 at elevation theta_1,max meets mirror 1 (z_max = f_z1(r_sys)). Mirror 1's
// elevation tends to the asymptote atan(sqrt((k - 2)/2)) as r grows, so for a k too close to 2 no
// finite r_sys reaches theta_1,max: that row has valid = false (alpha_1 -> 0 as k -> 2).
struct RsysVsKOptions {
  double c1 = 123.488;
  double theta1_min = -21.0974 * M_PI / 180.0;  // the big rig's optimum
  std::vector<double> alpha1 = {20 * M_PI / 180, 25 * M_PI / 180, 30 * M_PI / 180,
                                35 * M_PI / 180, 40 * M_PI / 180};
  double k_min = 2.5, k_max = 14.0;
  int k_samples = 47;
};
struct RsysVsKRow {
  double alpha1, k, r_sys, z_max;
  bool valid;
};
std::vector<RsysVsKRow> RsysVsK(const RsysVsKOptions& options);

// (b) baseline vs k1, [baseline_change_due_to_k]: k2, c2 and d fixed; mirror 1 must fill the same
// camera field of view alpha_cam and span the vertical FOV alpha (the curve family; the paper
// labels it alpha_SROI). For each k1, c1 = f_c1(k1) is found as follows. Mirror 1 scales with c1
// (camera at its outer focus), so
//  1. the camera's edge ray at alpha_cam / 2 from the axis meets mirror 1's rim at an elevation
//     theta_1,max(k1, alpha_cam) from F1 that does not depend on c1 ("just sees the rim");
//  2. theta_1,min = theta_1,max - alpha; the ray from F1 at theta_1,min meets mirror 1 at height
//     c1 * zeta(k1), and that point must lie on the reflex plane z = d/2: c1 = d / (2 zeta).
// Then r_sys' = c1 * rho(k1) and z_max' follow, and b = c1 + c2 - d. (The big rig's optimum, with
// alpha_cam = its lower camera-FOV bound 31.16 deg and alpha = alpha_1 = 35.10 deg, is a point of
// this family.) Rows where a ray misses mirror 1 are valid = false.
struct BaselineVsK1Options {
  double c2 = 241.803, d = 233.684;
  double alpha_cam = 31.1566 * M_PI / 180.0;
  std::vector<double> alpha = {30 * M_PI / 180, 35.0974 * M_PI / 180, 40 * M_PI / 180};
  double k1_min = 3.0, k1_max = 13.0;
  int k1_samples = 41;
};
struct BaselineVsK1Row {
  double alpha, k1, c1, r_sys, z_max, theta1_max, theta1_min, baseline;
  bool valid;
};
std::vector<BaselineVsK1Row> BaselineVsK1(const BaselineVsK1Options& options);

// (c) spatial resolution vs elevation for several k. Mirror i with fixed c_i (and d for mirror 2):
// elevations from theta_lo to theta_hi (the big rig's stereo ROI by default), r the radius of the
// mirror point on the ray from F_i at that elevation, eta_i [spatial_resolution_12] with focal
// length f_px and its 2-D version Resolution2D [resolution_in_2D_conversion]. The largest r of a
// curve (mirror 1: at theta_hi; mirror 2: at theta_lo) is the r_sys that k needs to keep that span.
struct ResolutionVsElevationOptions {
  DesignParams theta{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0};  // c1, c2, d used
  double f_px = 1450.0;
  double theta_lo = -13.9162 * M_PI / 180.0, theta_hi = 14.0 * M_PI / 180.0;
  std::vector<double> k1 = {3.0, 4.0, 5.7319, 8.0, 11.0};
  std::vector<double> k2 = {5.0, 7.0, 9.7443, 12.0, 14.0};
  int elevation_samples = 57;
};
struct ResolutionRow {
  int mirror;
  double k, elevation, r, eta, eta_2d;
  bool valid;
};
std::vector<ResolutionRow> ResolutionVsElevation(const ResolutionVsElevationOptions& options);

// CSV renderings with a header row (angles in degrees, lengths in mm, eta in px^2/sr).
std::string ToCsv(const std::vector<RsysVsKRow>& rows);
std::string ToCsv(const std::vector<BaselineVsK1Row>& rows);
std::string ToCsv(const std::vector<ResolutionRow>& rows);

}  // namespace omni::design
