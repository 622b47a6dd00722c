// Central camera models of other packages, as those packages define them, templated
// for Ceres: the fits (central_fit.h) and their evaluation use these, and the tests re-project
// the written files with their own Python copies of the same published formulas.
//
// Unified model (Geyer-Daniilidis / Mei; Kalibr "omni" + "radtan"): a point p = (x, y, z) on the
// unit sphere, seen from (0, 0, -xi): m = (x, y) / (z + xi |p|); radial-tangential distortion of
// m with (k1, k2, p1, p2) as OpenCV and Kalibr write it; pixel = (fu mx' + cu, fv my' + cv).
// Parameters: xi, fu, fv, cu, cv, k1, k2, p1, p2.
//
// Double sphere (Usenko, Demmel, Cremers 2018; basalt "ds"): d1 = |p|, k = xi d1 + z,
// d2 = |(x, y, k)|, pixel = (fx x, fy y) / (alpha d2 + (1 - alpha) k) + (cx, cy).
// Parameters: fx, fy, cx, cy, xi, alpha.
//
// A ring seen through one reflection more than the other is mirror-reversed: its fitted fv / fy
// is negative (central_fit.h), which both formulas take as they are.
#pragma once

#include <cmath>

namespace omni::exports {

inline constexpr int kUnifiedParameters = 9;
inline constexpr int kDoubleSphereParameters = 6;

template <typename T>
bool ProjectUnified(const T* q, const T* p, T* pixel) {
  using std::sqrt;
  const T d = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  const T den = p[2] + q[0] * d;
  if (!(den > T(1e-9) * d)) return false;
  const T mx = p[0] / den, my = p[1] / den;
  const T mx2 = mx * mx, my2 = my * my, mxy = mx * my, r2 = mx2 + my2;
  const T radial = q[5] * r2 + q[6] * r2 * r2;
  const T dx = mx * radial + T(2) * q[7] * mxy + q[8] * (r2 + T(2) * mx2);
  const T dy = my * radial + T(2) * q[8] * mxy + q[7] * (r2 + T(2) * my2);
  pixel[0] = q[1] * (mx + dx) + q[3];
  pixel[1] = q[2] * (my + dy) + q[4];
  return true;
}

template <typename T>
bool ProjectDoubleSphere(const T* q, const T* p, T* pixel) {
  using std::sqrt;
  const T d1 = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  const T k = q[4] * d1 + p[2];
  const T d2 = sqrt(p[0] * p[0] + p[1] * p[1] + k * k);
  const T den = q[5] * d2 + (T(1) - q[5]) * k;
  if (!(den > T(1e-9) * d1)) return false;
  pixel[0] = q[0] * p[0] / den + q[2];
  pixel[1] = q[1] * p[1] / den + q[3];
  return true;
}

}  // namespace omni::exports
