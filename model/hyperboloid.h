// One sheet of a hyperboloid of revolution about the z axis of its body frame: the paper's
// [hyperboloid] with [func_z], [func_r] and ray intersection. Mirror 1 is the UPPER sheet of the
// hyperboloid with foci (0,0,0) and (0,0,c1); mirror 2 the LOWER sheet of the one with foci
// (0,0,d-c2) and (0,0,d). All functions are templated so that ceres::Jet runs the same code.
#pragma once

#include <cmath>

#include "model/types.h"

namespace omni {

template <typename T>
struct HyperboloidSheet {
  // (z - z0)^2 / a^2 - r^2 / b^2 = 1 with a = c/2 sqrt((k-2)/k), b = c/2 sqrt(2/k) [hyperboloid].
  T z0;
  T a;
  T b;
  int sheet;  // +1: upper sheet (z > z0), -1: lower sheet (z < z0).

  // Mirror 1 in its body frame: z0 = c1/2 [z0_1], upper sheet [hyperboloid1].
  static HyperboloidSheet Mirror1(const T& c1, const T& k1) {
    return FromFoci(c1, k1, c1 / T(2), +1);
  }
  // Mirror 2 in its body frame: z0 = d - c2/2 [z0_2], lower sheet [hyperboloid2].
  static HyperboloidSheet Mirror2(const T& c2, const T& k2, const T& d) {
    return FromFoci(c2, k2, d - c2 / T(2), -1);
  }
  static HyperboloidSheet FromFoci(const T& c, const T& k, const T& z0, int sheet) {
    using std::sqrt;
    return HyperboloidSheet{z0, c / T(2) * sqrt((k - T(2)) / k), c / T(2) * sqrt(T(2) / k), sheet};
  }

  // Half the focal separation, c/2 = sqrt(a^2 + b^2).
  T HalfFocalSeparation() const {
    using std::sqrt;
    return sqrt(a * a + b * b);
  }
  // The focus the sheet wraps around (the SVP, F_i) and the other one (F_i', the camera's place).
  T PrimaryFocusZ() const { return z0 + T(sheet) * HalfFocalSeparation(); }
  T SecondaryFocusZ() const { return z0 - T(sheet) * HalfFocalSeparation(); }
  // The vertex of the sheet on the axis.
  T VertexZ() const { return z0 + T(sheet) * a; }

  // [func_z] without the radial limits: z of the sheet at radius r; gamma = a/b sqrt(b^2 + r^2).
  T Z(const T& r) const {
    using std::sqrt;
    return z0 + T(sheet) * a / b * sqrt(b * b + r * r);
  }
  // [func_r] without the radial limits: the non-negative radius at height z; false where the
  // plane z does not cut the sheet.
  bool R(const T& z, T* r) const {
    using std::sqrt;
    const T u = (z - z0) / a;
    if (T(sheet) * (z - z0) < a) return false;
    *r = b * sqrt(u * u - T(1));
    return true;
  }
  // dz/dr of the sheet at radius r.
  T Slope(const T& r) const {
    using std::sqrt;
    return T(sheet) * a / b * r / sqrt(b * b + r * r);
  }

  // Implicit function F(p) = (z - z0)^2/a^2 - (x^2 + y^2)/b^2 - 1, zero on the surface.
  T Implicit(const Vec3<T>& p) const {
    const T dz = p.z() - z0;
    return dz * dz / (a * a) - (p.x() * p.x() + p.y() * p.y()) / (b * b) - T(1);
  }
  // Unit surface normal at a surface point, grad F / |grad F|. On the surface sign(z - z0) = sheet,
  // so it points away from the plane z = z0, into the region that holds the primary focus.
  Vec3<T> Normal(const Vec3<T>& p) const {
    Vec3<T> g(-p.x() / (b * b), -p.y() / (b * b), (p.z() - z0) / (a * a));
    return g / g.norm();
  }

  // Smallest t > t_min with origin + t * dir on this sheet; false if none.
  bool IntersectRay(const Vec3<T>& origin, const Vec3<T>& dir, T* t, const T& t_min = T(1e-9)) const {
    using std::abs;
    using std::sqrt;
    const T ia2 = T(1) / (a * a);
    const T ib2 = T(1) / (b * b);
    const T oz = origin.z() - z0;
    const T qa = dir.z() * dir.z() * ia2 - (dir.x() * dir.x() + dir.y() * dir.y()) * ib2;
    const T qb = T(2) * (oz * dir.z() * ia2 - (origin.x() * dir.x() + origin.y() * dir.y()) * ib2);
    const T qc = oz * oz * ia2 - (origin.x() * origin.x() + origin.y() * origin.y()) * ib2 - T(1);
    T roots[2];
    int n = 0;
    const T scale = abs(qb) + abs(qc) + T(1e-300);
    if (abs(qa) <= T(1e-14) * scale) {
      if (qb == T(0)) return false;
      roots[n++] = -qc / qb;
    } else {
      const T disc = qb * qb - T(4) * qa * qc;
      if (disc < T(0)) return false;
      const T sq = sqrt(disc);
      // Numerically stable pair of roots.
      const T q = qb >= T(0) ? T(-0.5) * (qb + sq) : T(-0.5) * (qb - sq);
      roots[n++] = q / qa;
      if (q != T(0)) roots[n++] = qc / q;
    }
    bool found = false;
    T best = T(0);
    for (int i = 0; i < n; ++i) {
      const T ti = roots[i];
      if (!(ti > t_min)) continue;
      const T z = origin.z() + ti * dir.z();
      if (T(sheet) * (z - z0) <= T(0)) continue;  // the other sheet
      if (!found || ti < best) {
        best = ti;
        found = true;
      }
    }
    if (found) *t = best;
    return found;
  }
};

// Reflects direction v about a plane with unit normal n: v - 2 (v.n) n.
template <typename T>
Vec3<T> Reflect(const Vec3<T>& v, const Vec3<T>& n) {
  return v - T(2) * v.dot(n) * n;
}

}  // namespace omni
