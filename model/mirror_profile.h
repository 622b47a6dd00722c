// A machined mirror's profile error: a smooth sag correction on top of the conic.
//
// A CNC-machined mirror is not an exact hyperboloid. Its surface in the mirror's body frame is
//   z(x, y) = Z(r) + sag(x, y),   r = sqrt(x^2 + y^2)
// with Z the conic sheet ([func_z], hyperboloid.h) and the sag along the body's +z axis (mm):
//   sag = sum_{n=1..4} sag_pn P_n(w)                      rotationally symmetric part
//       + (sag_cos2 (x^2 - y^2) + sag_sin2 2 x y) / r_max^2  astigmatism (cos 2 theta, sin 2 theta)
//       + ripple_amplitude sin(2 pi r / ripple_period + ripple_phase)   machining marks
// where P_n are the Legendre polynomials and w = 2 (r^2 - r_min^2) / (r_max^2 - r_min^2) - 1 maps
// the profile's radii [r_min, r_max] (by default the mirror's used annulus) to [-1, 1]. Over
// those radii P_n(w) runs between -1 and +1, so |sag_pn| is half that term's peak-to-valley.
// The symmetric terms are polynomials in r^2, so the surface is smooth on the axis too.
//
// The six coefficients (sag_p1..sag_p4, sag_cos2, sag_sin2) are a parameter block of the rig
// (RigParams::mirror1_profile / mirror2_profile, model/rig_parameters.h) that a calibration can
// refine; the radii and the ripple are fixed data (the ripple describes a rendered or measured
// surface; no calibration refines it). A constant sag is left out on purpose: it is the mirror's
// axial position (tz).
#pragma once

#include <array>
#include <cmath>

#include "model/types.h"

namespace omni {

inline constexpr int kProfileTerms = 6;  // sag_p1..sag_p4, sag_cos2, sag_sin2

// The fixed part of a mirror's profile.
struct ProfileShape {
  bool present = false;  // false: the exact conic (the coefficients are not read)
  double r_min = 0, r_max = 0;  // the radii w's [-1, 1] spans (mm)
  double ripple_amplitude = 0, ripple_period = 0, ripple_phase = 0;  // mm, mm, rad
};

// The sag and its first and second derivatives at (x, y).
template <typename T>
struct Sag {
  T z{0}, zx{0}, zy{0}, zxx{0}, zxy{0}, zyy{0};
};

// Legendre P_1..P_4 at w and their first and second derivatives, summed with coefficients c.
template <typename T>
void LegendreSum(const T* c, const T& w, T* value, T* first, T* second) {
  const T w2 = w * w;
  *value = c[0] * w + c[1] * (T(1.5) * w2 - T(0.5)) + c[2] * (T(2.5) * w2 - T(1.5)) * w +
           c[3] * ((T(4.375) * w2 - T(3.75)) * w2 + T(0.375));
  *first = c[0] + c[1] * T(3) * w + c[2] * (T(7.5) * w2 - T(1.5)) +
           c[3] * (T(17.5) * w2 - T(7.5)) * w;
  *second = c[1] * T(3) + c[2] * T(15) * w + c[3] * (T(52.5) * w2 - T(7.5));
}

// The sag of a profile with coefficients `coeffs` (kProfileTerms) at (x, y) in the mirror's body
// frame, with derivatives (second ones only if `second` is true).
template <typename T>
Sag<T> ProfileSag(const T* coeffs, const ProfileShape& shape, const T& x, const T& y,
                  bool second = true) {
  Sag<T> s;
  const double span = shape.r_max * shape.r_max - shape.r_min * shape.r_min;
  const double kappa = 4.0 / span;  // dw/d(r^2) * 2
  const T r2 = x * x + y * y;
  const T w = (r2 - T(shape.r_min * shape.r_min)) * T(2.0 / span) - T(1);
  T value, first, sec;
  LegendreSum(coeffs, w, &value, &first, &sec);
  // dw/dx = kappa x, dw/dy = kappa y.
  s.z = value;
  s.zx = first * T(kappa) * x;
  s.zy = first * T(kappa) * y;
  if (second) {
    const T k2 = sec * T(kappa * kappa);
    s.zxx = k2 * x * x + first * T(kappa);
    s.zxy = k2 * x * y;
    s.zyy = k2 * y * y + first * T(kappa);
  }
  // Astigmatism.
  const double inv_rm2 = 1.0 / (shape.r_max * shape.r_max);
  const T& ac = coeffs[4];
  const T& as = coeffs[5];
  s.z += (ac * (x * x - y * y) + as * T(2) * x * y) * T(inv_rm2);
  s.zx += (ac * x + as * y) * T(2 * inv_rm2);
  s.zy += (as * x - ac * y) * T(2 * inv_rm2);
  if (second) {
    s.zxx += ac * T(2 * inv_rm2);
    s.zyy -= ac * T(2 * inv_rm2);
    s.zxy += as * T(2 * inv_rm2);
  }
  // Ripple (fixed data: no coefficient of the block).
  if (shape.ripple_amplitude != 0 && shape.ripple_period > 0) {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const double omega = 2 * M_PI / shape.ripple_period;
    const T rho = sqrt(r2 + T(1e-18));
    const T phase = T(omega) * rho + T(shape.ripple_phase);
    const T d1 = T(shape.ripple_amplitude * omega) * cos(phase);  // d sag / d rho
    s.z += T(shape.ripple_amplitude) * sin(phase);
    const T inv_rho = T(1) / rho;
    s.zx += d1 * x * inv_rho;
    s.zy += d1 * y * inv_rho;
    if (second) {
      const T d2 = T(-shape.ripple_amplitude * omega * omega) * sin(phase);
      const T inv_rho2 = inv_rho * inv_rho;
      const T inv_rho3 = inv_rho2 * inv_rho;
      s.zxx += d2 * x * x * inv_rho2 + d1 * y * y * inv_rho3;
      s.zyy += d2 * y * y * inv_rho2 + d1 * x * x * inv_rho3;
      s.zxy += (d2 * inv_rho2 - d1 * inv_rho3) * x * y;
    }
  }
  return s;
}

// The largest |sag| and |grad sag| of a profile over its radii and all azimuths (sampled every
// 0.05 mm of radius and 1 degree): what the model file's bounds check.
struct ProfileExtent {
  double max_sag_mm = 0;
  double max_slope = 0;  // |grad sag|, rad
};
ProfileExtent MeasureProfile(const std::array<double, kProfileTerms>& coeffs,
                             const ProfileShape& shape);

}  // namespace omni
