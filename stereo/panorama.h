// Panoramas of both rings [cylinder_height]..[panorama_pixel_mapping_function] for ANY rig model,
// through look-up tables (LUT_Xi_i) and cv::remap.
//
// Geometry (the paper's section "Panoramic Images", generalised to a non-central rig):
//  - Viewpoints: each mirror's primary focus in C, F1 = cam_from_mirror1 (0, 0, c1) and
//    F2 = cam_from_mirror2 (0, 0, d - c2). For the ideal rig these are the single viewpoints; for a
//    misaligned rig they are the points the rays of each ring pass closest to (within the
//    misalignment), and what the paper's [point_in_cylindrical_panorama] uses.
//  - Cylinder axis: the baseline direction a = (F1 - F2) / |F1 - F2| (= +z of C on the ideal
//    rig), so that both cylinders are coaxial and epipolar lines are exactly the panorama
//    columns for rays through F1 and F2. Azimuth 0 is C's +x axis projected normal to a.
//  - Rows and columns: psi(u) = 2 pi - u l_px [azimuth_inference_from_column_in_panoramic_image]
//    (the paper's column order reversal), tan(theta(v)) = z_cyl,max - v l_px
//    [elevation_inference_from_row_in_panoramic_image], pixel centres at integer u, v.
//    z_cyl,max/min = tan(theta_sys,max/min) [cylinder_height] from the ideal model's elevation
//    limits [vFOV_system]; l_px = 2 pi / w = h_cyl / h [panorama_pixel_size].
//  - Cylinder radius: the paper's unit cylinder only works for a central model (a point 1 mm from
//    the focus is a direction). A non-central model projects the 3D point
//    F_i + R (r cos psi, r sin psi, r tan theta) on a cylinder of radius r = cylinder_radius_mm
//    (default 2 m); the LUT is exact for scene points at that range and, for the misalignments
//    of a real rig, within a small fraction of a pixel elsewhere.
//  - A single-mirror rig (RigParams::Single) has one ring and so one panorama: its viewpoint is
//    its mirror's near focus and the cylinder's axis the mirror's (model_derived.h); its
//    elevation limits come from its conic (RigFieldOfView). Ring 2's members are left empty.
//  - LUT entry = the raw pixel of that point via mirror i (RigModel::Project, so lens distortion
//    and misalignment are included) [panorama_pixel_mapping_function]; -1 where invalid.
#pragma once

#include <array>
#include <limits>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_model.h"

namespace omni::stereo {

struct PanoramaOptions {
  int width = 1280;                  // w_Xi (columns); the height follows [panorama_pixel_size]
  double cylinder_radius_mm = 2000;  // r of the projection cylinder (see the file comment)
  // Elevation limits (rad); NaN: theta_sys,min/max of the rig [cylinder_height]
  // (RigFieldOfView, model_derived.h).
  double theta_min = std::numeric_limits<double>::quiet_NaN();
  double theta_max = std::numeric_limits<double>::quiet_NaN();

  // Empty if the options are consistent, else what is wrong (names the field). The elevation
  // limits are checked against the model's (MakePanoramaGeometry).
  std::string Check() const;
};

struct PanoramaGeometry {
  int rings = 2;  // the rig's optical paths (RigParams::Paths): [0] only when 1
  int width = 0, height = 0;
  double l_px = 0;                     // [panorama_pixel_size], unit-cylinder length per pixel
  double z_max = 0, z_min = 0;         // tan(theta_max), tan(theta_min)
  double radius_mm = 0;
  std::array<Eigen::Vector3d, 2> viewpoint_in_cam;  // F1, F2 (a single rig: F2 NaN)
  Eigen::Matrix3d cam_from_cylinder = Eigen::Matrix3d::Identity();  // columns: x, y, axis

  double Azimuth(double u) const;      // [azimuth_inference_from_column_in_panoramic_image]
  double Elevation(double v) const;    // [elevation_inference_from_row_in_panoramic_image]
  double RowOfElevation(double theta) const;
  // [point_in_cylindrical_panorama] on the cylinder of radius radius_mm at F_mirror.
  Eigen::Vector3d PointOnCylinder(Mirror mirror, double u, double v) const;
  // Panorama (u, v) of the direction of point_in_cam seen from F_mirror.
  Eigen::Vector2d PanoramaPixel(Mirror mirror, const Eigen::Vector3d& point_in_cam) const;
};

PanoramaGeometry MakePanoramaGeometry(const RigModel& model, const PanoramaOptions& options);

// The look-up tables of both panoramas: map_x / map_y (CV_32FC1, raw pixel; -1 where the
// mirror does not see that cylinder point) and the same in OpenCV's fixed-point form for a fast
// cv::remap.
struct PanoramaLuts {
  PanoramaGeometry geometry;
  // [0]: mirror 1 (Xi_1), [1]: mirror 2 (Xi_2); only [0] for a single rig (geometry.rings 1).
  std::array<cv::Mat, 2> map_x, map_y;
  std::array<cv::Mat, 2> fixed_xy, fixed_frac;  // cv::convertMaps(CV_16SC2)
  std::array<cv::Range, 2> valid_rows;          // rows with at least one valid entry
};

// Projects every panorama pixel via its mirror (parallel over rows).
PanoramaLuts BuildPanoramaLuts(const RigModel& model, const PanoramaOptions& options);

// Panorama Xi_mirror of a raw image (any type cv::remap takes), bilinear, black where invalid.
// Only the rows the mirror sees are remapped (the rest is set to black). The mirror must be one
// of the rig's rings (std::invalid_argument: mirror 2 of a single rig).
void Unwarp(const cv::Mat& image, const PanoramaLuts& luts, Mirror mirror, cv::Mat* panorama);
// The same for the panorama rows `rows` alone (the rest black): what a caller that reads only a
// band (dense stereo) needs, at that band's share of the cost.
void Unwarp(const cv::Mat& image, const PanoramaLuts& luts, Mirror mirror, cv::Range rows,
            cv::Mat* panorama);

}  // namespace omni::stereo
