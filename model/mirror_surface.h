// A mirror's reflecting surface in its body frame: the conic sheet (the folded rig's
// hyperboloids: hyperboloid.h; a single-mirror rig's conic of any kind: conic_sheet.h) plus,
// where the model has one, its profile correction (mirror_profile.h). Every optical path reflects on
// this type, so the exact quadric and the machined mirror share one code path; with no profile
// each function reduces to the conic's closed form.
#pragma once

#include <array>
#include <cmath>

#include "model/conic_sheet.h"
#include "model/hyperboloid.h"
#include "model/mirror_profile.h"
#include "model/types.h"

namespace omni {

template <typename T>
struct MirrorSurface {
  HyperboloidSheet<T> conic;               // the folded rig's sheet (general false)
  bool general = false;                    // true: the conic below (single-mirror rigs)
  ConicSheet<T> general_conic{T(0), T(0), T(0)};
  ProfileShape shape;                      // shape.present false: the exact conic
  std::array<T, kProfileTerms> coeffs{};   // read only where shape.present

  MirrorSurface() = default;
  MirrorSurface(const HyperboloidSheet<T>& sheet, const ProfileShape& profile_shape,
                const T* profile)
      : conic(sheet), shape(profile_shape) {
    if (!profile) shape.present = false;
    if (shape.present) {
      for (int i = 0; i < kProfileTerms; ++i) coeffs[i] = profile[i];
    }
  }
  MirrorSurface(const ConicSheet<T>& sheet, const ProfileShape& profile_shape, const T* profile)
      : general(true), general_conic(sheet), shape(profile_shape) {
    if (!profile) shape.present = false;
    if (shape.present) {
      for (int i = 0; i < kProfileTerms; ++i) coeffs[i] = profile[i];
    }
  }
  bool Profiled() const { return shape.present; }
  // +1: the sheet's normal points towards +z (mirror 1 of either rig); -1: towards -z.
  int SheetSign() const { return general ? 1 : conic.sheet; }

  // z of the surface at (x, y) with dz/dx, dz/dy and (hessian != nullptr) the second
  // derivatives [zxx, zxy, zyy]. The conic's z without a square root of r^2 (smooth on the axis).
  T Z(const T& x, const T& y, T* zx = nullptr, T* zy = nullptr, T* hessian = nullptr) const {
    using std::sqrt;
    if (general) return AddProfile(general_conic.Z(x, y, zx, zy, hessian), x, y, zx, zy, hessian);
    const T q2 = conic.b * conic.b + x * x + y * y;
    const T q = sqrt(q2);
    const T inv_q = T(1) / q;
    const T k = T(conic.sheet) * conic.a / conic.b;
    T z = conic.z0 + k * q;
    const T k_inv_q = k * inv_q;
    if (zx) *zx = k_inv_q * x;
    if (zy) *zy = k_inv_q * y;
    if (hessian) {
      const T k_inv_q3 = k_inv_q * inv_q * inv_q;
      hessian[0] = k_inv_q3 * (q2 - x * x);
      hessian[1] = -k_inv_q3 * x * y;
      hessian[2] = k_inv_q3 * (q2 - y * y);
    }
    return AddProfile(z, x, y, zx, zy, hessian);
  }
  // The profile's sag and its derivatives added to the conic's.
  T AddProfile(T z, const T& x, const T& y, T* zx, T* zy, T* hessian) const {
    if (shape.present) {
      const Sag<T> s = ProfileSag(coeffs.data(), shape, x, y, hessian != nullptr);
      z += s.z;
      if (zx) *zx += s.zx;
      if (zy) *zy += s.zy;
      if (hessian) {
        hessian[0] += s.zxx;
        hessian[1] += s.zxy;
        hessian[2] += s.zyy;
      }
    }
    return z;
  }

  Vec3<T> Point(const T& x, const T& y) const { return Vec3<T>(x, y, Z(x, y)); }

  // Unit normal at the surface point above (p.x, p.y), oriented as the conic's
  // (HyperboloidSheet::Normal): into the region that holds the primary focus, i.e. away from the
  // reflective side.
  Vec3<T> Normal(const Vec3<T>& p) const {
    if (!shape.present) return general ? general_conic.Normal(p) : conic.Normal(p);
    T zx, zy;
    Z(p.x(), p.y(), &zx, &zy);
    // The surface is z - Z(x, y) = 0; the conic's normal has the sign of sheet in z.
    const Vec3<T> g = T(SheetSign()) * Vec3<T>(-zx, -zy, T(1));
    return g / g.norm();
  }

  // Smallest t > t_min with origin + t * dir on the surface; false if none. The conic's hit,
  // then Newton on h(t) = z(t) - Z(x(t), y(t)) (a profile moves it by microns).
  bool IntersectRay(const Vec3<T>& origin, const Vec3<T>& dir, T* t,
                    const T& t_min = T(1e-9)) const {
    using std::abs;
    if (!(general ? general_conic.IntersectRay(origin, dir, t, t_min)
                  : conic.IntersectRay(origin, dir, t, t_min))) {
      return false;
    }
    if (!shape.present) return true;
    for (int iter = 0; iter < 20; ++iter) {
      const Vec3<T> p = origin + *t * dir;
      T zx, zy;
      const T h = p.z() - Z(p.x(), p.y(), &zx, &zy);
      const T dh = dir.z() - zx * dir.x() - zy * dir.y();
      if (!(abs(dh) > T(1e-12))) return false;
      const T step = h / dh;
      *t -= step;
      if (abs(step) < T(1e-12)) return *t > t_min;
    }
    return false;
  }
};

}  // namespace omni
