// Design-level quantities of the ideal rig (double precision, no image needed): elevation limits
// and fields of view [alpha12]..[common_FOV_limit_angles], stereo-ROI near vertices, triangulation
// from elevations [depth_from_triangulation], [pw_from_triangulation], camera-FOV bounds
// [camera_FOV_nonequality_constraint], hole radius [r_cam], spatial resolution
// [resolution_of_camera]..[spatial_resolution_12], [resolution_in_2D_conversion], size and mass
// [height]..[volume_reflex_mirror], the imaging ratio chi, and the reflex-radius equality h1.
#pragma once

#include <vector>

#include "model/ideal_model.h"

namespace omni {

// Elevation (rad) seen from F_i of mirror i's surface point at radius r: atan2(z_i(r) - f_i, r).
double ElevationOfMirrorRadius(const DesignParams& theta, Mirror mirror, double r);

// The reflex radius the design implies: f_r1(d/2) (where mirror 1 meets the reflex plane).
// Returns 0 when the plane z = d/2 misses mirror 1.
double ReflexRadius(const DesignParams& theta);
// The radius where the virtual camera's sight line to mirror 2's rim crosses z = d/2.
double ReflexRadiusNeededByMirror2(const DesignParams& theta);

struct FieldOfView {
  double theta1_max, theta1_min, theta2_max, theta2_min;  // [theta1_limits], rad
  double alpha1, alpha2;                                   // [alpha1], [alpha2]
  double alpha_sys;                                        // [vFOV_system]
  double theta_sys_min, theta_sys_max;                     // its limits: min / max of both rings'
  double theta_sroi_min, theta_sroi_max, alpha_sroi;       // [common_FOV_limit_angles], [vFOV_common]
};
// theta1: mirror 1 between r_ref (min) and r_sys (max); theta2: mirror 2 between r_sys (min) and
// r_cam (max).
FieldOfView ComputeFieldOfView(const DesignParams& theta, double r_ref, double r_cam);

// Triangulation of two coplanar rays from F1 and F2 with elevations theta1, theta2 and common
// azimuth psi [function_triangulation]: horizontal range [depth_from_triangulation] and the point
// p = (rho cos psi, rho sin psi, c1 + rho tan theta1) (the paper's [pw_from_triangulation] writes
// the azimuth of the opposite direction; see docs/reproduction.md). False for parallel rays.
bool TriangulateElevations(const DesignParams& theta, double theta1, double theta2, double psi,
                           Eigen::Vector3d* point_in_cam, double* rho = nullptr);

struct StereoRoiVertices {  // (rho, z) in mm of the near vertices of the stereo ROI
  Eigen::Vector2d high, mid, low;
};
StereoRoiVertices ComputeStereoRoiVertices(const DesignParams& theta, const FieldOfView& fov);

// [camera_FOV_nonequality_constraint]: the camera's full FOV must see mirror 1's rim and pass the
// hole of mirror 2: lower <= alpha_cam <= upper (rad).
struct CameraFovBounds {
  double lower, upper;
};
CameraFovBounds ComputeCameraFovBounds(const DesignParams& theta, double r_cam);
// r_alpha_cam: the hole radius that just clears a camera of full field of view alpha_cam, and
// [r_cam] = max(r_lens, r_alpha_cam).
double HoleRadiusForCameraFov(const DesignParams& theta, double alpha_cam);
double HoleRadius(const DesignParams& theta, double r_lens, double alpha_cam);

// Spatial resolution of mirror i at its surface radius r, f in pixels:
// eta_cam [resolution_of_camera_toward_mirror_point] and eta_i [spatial_resolution_12], px^2/sr.
struct Resolution {
  double eta_cam, eta;
  double elevation;  // of the ray from F_i, rad
};
Resolution SpatialResolution(const DesignParams& theta, Mirror mirror, double r, double f_px);
// [resolution_in_2D_conversion]: 2 sqrt(eta / pi) / theta_Omega(1 sr).
double Resolution2D(double eta);

// Size and mass [height]..[volume_reflex_mirror]. Lengths mm, densities g/cm^3, masses g.
struct MassInputs {
  double mirror_wall_mm = 1.0;        // tau_m
  double mirror_density = 8.5;        // brass
  double camera_mass_g = 25.0;        // m_cam
  double tube_wall_mm = 1.5;          // support tube of radius r_sys and height h_sys
  double tube_density = 1.18;         // acrylic
};
struct SizeAndMass {
  double h_sys;                  // [height]
  double z_max, z_min;           // f_z1(r_sys), f_z2(r_sys)
  double v1_mm3, v2_mm3, v_ref_mm3;
  double m_mirrors_g, m_tube_g, m_cam_g, m_sys_g;  // [mass_sys], [mass_mirror]
  double m_authors_g;  // the authors' simplified W = pi 2.5 h (0.6 r + 0.09) (cm, g)
};
SizeAndMass ComputeSizeAndMass(const DesignParams& theta, double r_ref, double r_cam,
                               const MassInputs& inputs);

// Imaging ratio chi = h_I1 / h_I2: radial image extents of the stereo ROI in ring 1 and ring 2
// (independent of the focal length).
double ImagingRatio(const DesignParams& theta, const FieldOfView& fov);

}  // namespace omni
