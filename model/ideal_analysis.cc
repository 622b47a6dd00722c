#include "model/ideal_analysis.h"

#include <algorithm>
#include <cmath>

namespace omni {
namespace {

HyperboloidSheet<double> Sheet(const DesignParams& theta, Mirror mirror) {
  return mirror == Mirror::kOne ? HyperboloidSheet<double>::Mirror1(theta.c1, theta.k1)
                                : HyperboloidSheet<double>::Mirror2(theta.c2, theta.k2, theta.d);
}

double FocusZ(const DesignParams& theta, Mirror mirror) {
  return mirror == Mirror::kOne ? theta.c1 : theta.d - theta.c2;
}

// Radius of mirror i's surface point on the ray from F_i at the given elevation; false if missed.
bool MirrorRadiusForElevation(const DesignParams& theta, Mirror mirror, double elevation,
                              double* r) {
  const auto sheet = Sheet(theta, mirror);
  const Eigen::Vector3d focus(0, 0, FocusZ(theta, mirror));
  const Eigen::Vector3d dir(std::cos(elevation), 0, std::sin(elevation));
  double t = 0;
  if (!sheet.IntersectRay(focus, dir, &t)) return false;
  *r = t * dir.x();
  return true;
}

// Normalised image radius (|q|) of mirror i's surface point at radius r: r / z1 for mirror 1,
// r / (d - z2) through the virtual camera for mirror 2 [m1], [m2].
double NormalizedImageRadius(const DesignParams& theta, Mirror mirror, double r) {
  const double z = Sheet(theta, mirror).Z(r);
  return mirror == Mirror::kOne ? r / z : r / (theta.d - z);
}

// Composite Simpson's rule over [lo, hi].
template <typename F>
double Integrate(F f, double lo, double hi, int n = 2000) {
  const double h = (hi - lo) / n;
  double sum = f(lo) + f(hi);
  for (int i = 1; i < n; ++i) sum += f(lo + i * h) * (i % 2 ? 4.0 : 2.0);
  return sum * h / 3.0;
}

// Shell volume of a mirror between two radii, [mirror_area] integrated over z
// [volume_mirror_hyperboloid].
double ShellVolume(const DesignParams& theta, Mirror mirror, double r_lo, double r_hi,
                   double wall) {
  const auto sheet = Sheet(theta, mirror);
  const double z_a = sheet.Z(r_lo), z_b = sheet.Z(r_hi);
  auto ring_area = [&](double z) {
    double r = 0;
    if (!sheet.R(z, &r)) r = 0;
    return M_PI * wall * (2 * r - wall);
  };
  return Integrate(ring_area, std::min(z_a, z_b), std::max(z_a, z_b));
}

}  // namespace

double ElevationOfMirrorRadius(const DesignParams& theta, Mirror mirror, double r) {
  return std::atan2(Sheet(theta, mirror).Z(r) - FocusZ(theta, mirror), r);
}

double ReflexRadius(const DesignParams& theta) {
  double r = 0;
  if (!Sheet(theta, Mirror::kOne).R(theta.d / 2, &r)) return 0;
  return r;
}

double ReflexRadiusNeededByMirror2(const DesignParams& theta) {
  const double z_rim = Sheet(theta, Mirror::kTwo).Z(theta.r_sys);
  return theta.r_sys * (theta.d / 2) / (theta.d - z_rim);
}

FieldOfView ComputeFieldOfView(const DesignParams& theta, double r_ref, double r_cam) {
  FieldOfView f;
  f.theta1_max = ElevationOfMirrorRadius(theta, Mirror::kOne, theta.r_sys);
  f.theta1_min = ElevationOfMirrorRadius(theta, Mirror::kOne, r_ref);
  f.theta2_min = ElevationOfMirrorRadius(theta, Mirror::kTwo, theta.r_sys);
  f.theta2_max = ElevationOfMirrorRadius(theta, Mirror::kTwo, r_cam);
  f.alpha1 = f.theta1_max - f.theta1_min;
  f.alpha2 = f.theta2_max - f.theta2_min;
  f.theta_sys_min = std::min(f.theta1_min, f.theta2_min);
  f.theta_sys_max = std::max(f.theta1_max, f.theta2_max);
  f.alpha_sys = f.theta_sys_max - f.theta_sys_min;
  f.theta_sroi_min = std::max(f.theta1_min, f.theta2_min);
  f.theta_sroi_max = std::min(f.theta1_max, f.theta2_max);
  f.alpha_sroi = f.theta_sroi_max - f.theta_sroi_min;
  return f;
}

bool TriangulateElevations(const DesignParams& theta, double theta1, double theta2, double psi,
                           Eigen::Vector3d* point_in_cam, double* rho_out) {
  // z = c1 + rho tan(theta1) = (d - c2) + rho tan(theta2)  =>  rho = b / (tan2 - tan1), which is
  // [depth_from_triangulation] b cos1 cos2 / sin(theta2 - theta1).
  const double b = theta.c1 + theta.c2 - theta.d;
  const double s = std::sin(theta2 - theta1);
  if (std::abs(s) < 1e-15) return false;
  const double rho = b * std::cos(theta1) * std::cos(theta2) / s;
  if (!(rho > 0)) return false;  // the rays diverge
  *point_in_cam = Eigen::Vector3d(rho * std::cos(psi), rho * std::sin(psi),
                                  theta.c1 + rho * std::tan(theta1));
  if (rho_out) *rho_out = rho;
  return true;
}

StereoRoiVertices ComputeStereoRoiVertices(const DesignParams& theta, const FieldOfView& fov) {
  auto vertex = [&](double t1, double t2) {
    Eigen::Vector3d p;
    double rho = 0;
    if (!TriangulateElevations(theta, t1, t2, 0.0, &p, &rho)) {
      return Eigen::Vector2d(std::nan(""), std::nan(""));
    }
    return Eigen::Vector2d(rho, p.z());
  };
  StereoRoiVertices v;
  v.high = vertex(fov.theta1_max, fov.theta2_max);
  v.mid = vertex(fov.theta1_min, fov.theta2_max);
  v.low = vertex(fov.theta1_min, fov.theta2_min);
  return v;
}

CameraFovBounds ComputeCameraFovBounds(const DesignParams& theta, double r_cam) {
  const double z1_rim = Sheet(theta, Mirror::kOne).Z(theta.r_sys);
  const double z2_hole = Sheet(theta, Mirror::kTwo).Z(r_cam);
  return {2 * std::atan(theta.r_sys / z1_rim), 2 * std::atan(r_cam / z2_hole)};
}

double HoleRadiusForCameraFov(const DesignParams& theta, double alpha_cam) {
  // r / f_z2(r) grows with r on mirror 2's lower sheet; bisection for r / z = tan(alpha/2).
  const auto sheet = Sheet(theta, Mirror::kTwo);
  const double target = std::tan(alpha_cam / 2);
  double lo = 0, hi = theta.r_sys;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    const double z = sheet.Z(mid);
    if (z > 0 && mid / z < target) lo = mid; else hi = mid;
  }
  return 0.5 * (lo + hi);
}

double HoleRadius(const DesignParams& theta, double r_lens, double alpha_cam) {
  return std::max(r_lens, HoleRadiusForCameraFov(theta, alpha_cam));  // [r_cam]
}

Resolution SpatialResolution(const DesignParams& theta, Mirror mirror, double r, double f_px) {
  const double z = Sheet(theta, mirror).Z(r);
  Resolution out;
  out.elevation = ElevationOfMirrorRadius(theta, mirror, r);
  if (mirror == Mirror::kOne) {
    const double ratio = std::sqrt(r * r + z * z) / z;
    out.eta_cam = f_px * f_px * ratio * ratio * ratio;
    out.eta = (r * r + (theta.c1 - z) * (theta.c1 - z)) / (r * r + z * z) * out.eta_cam;
  } else {
    const double depth = theta.d - z;
    const double ratio = std::sqrt(r * r + depth * depth) / depth;
    out.eta_cam = f_px * f_px * ratio * ratio * ratio;
    const double dz = theta.c2 - theta.d + z;
    out.eta = (r * r + dz * dz) / (r * r + depth * depth) * out.eta_cam;
  }
  return out;
}

double Resolution2D(double eta) {
  const double theta_one_sr = 2 * std::acos(1 - 1 / (2 * M_PI));  // ~1.14390752211 rad
  return 2 * std::sqrt(eta / M_PI) / theta_one_sr;
}

SizeAndMass ComputeSizeAndMass(const DesignParams& theta, double r_ref, double r_cam,
                               const MassInputs& in) {
  SizeAndMass s;
  s.z_max = Sheet(theta, Mirror::kOne).Z(theta.r_sys);
  s.z_min = Sheet(theta, Mirror::kTwo).Z(theta.r_sys);
  s.h_sys = s.z_max - s.z_min;
  s.v1_mm3 = ShellVolume(theta, Mirror::kOne, r_ref, theta.r_sys, in.mirror_wall_mm);
  s.v2_mm3 = ShellVolume(theta, Mirror::kTwo, r_cam, theta.r_sys, in.mirror_wall_mm);
  s.v_ref_mm3 = in.mirror_wall_mm * M_PI * r_ref * r_ref;  // [volume_reflex_mirror]
  s.m_mirrors_g = (s.v1_mm3 + s.v2_mm3 + s.v_ref_mm3) / 1000.0 * in.mirror_density;
  const double r_out = theta.r_sys + in.tube_wall_mm;
  s.m_tube_g = M_PI * (r_out * r_out - theta.r_sys * theta.r_sys) * s.h_sys / 1000.0 *
               in.tube_density;
  s.m_cam_g = in.camera_mass_g;
  s.m_sys_g = s.m_cam_g + s.m_tube_g + s.m_mirrors_g;
  s.m_authors_g = M_PI * 2.5 * (s.h_sys / 10) * (0.6 * theta.r_sys / 10 + 0.09);
  return s;
}

double ImagingRatio(const DesignParams& theta, const FieldOfView& fov) {
  double extent[2];
  for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
    double r_lo = 0, r_hi = 0;
    if (!MirrorRadiusForElevation(theta, m, fov.theta_sroi_min, &r_lo) ||
        !MirrorRadiusForElevation(theta, m, fov.theta_sroi_max, &r_hi)) {
      return std::nan("");
    }
    extent[MirrorIndex(m) - 1] = std::abs(NormalizedImageRadius(theta, m, r_hi) -
                                          NormalizedImageRadius(theta, m, r_lo));
  }
  return extent[0] / extent[1];
}

}  // namespace omni
