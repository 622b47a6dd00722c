// A conic mirror of any kind (conic.h: vertex radius of curvature R, conic constant K) placed in
// a mirror's body frame: axis z, vertex at (0, 0, vertex_z), opening towards +z (the sag grows
// upwards, so a camera below sees the convex side), as a single-mirror rig's mirror 1 (the
// folded rig's hyperboloids: hyperboloid.h). The surface functions MirrorSurface needs, in
// closed form, templated on the scalar:
//   z(r) = vertex_z + s(r^2),  s = r^2 / (R + sqrt(R^2 - (1 + K) r^2)),
//   dz/dx = g x,  g = 1 / (R - (1 + K) s)   (conic.h, SlopeOverRadius),
//   d2z/dx2 = g + (1 + K) g^3 x^2,  d2z/dxdy = (1 + K) g^3 x y   (from dg/dx = (1 + K) g^3 x).
// The sheet is the branch through the vertex: R - (1 + K) s > 0 (the hyperboloid's near sheet,
// the ellipsoid's and sphere's half towards the vertex).
#pragma once

#include <cmath>

#include "model/conic.h"
#include "model/types.h"

namespace omni {

template <typename T>
struct ConicSheet {
  T R;         // vertex radius of curvature (mm), > 0
  T K;         // conic constant
  T vertex_z;  // the vertex's height in the body frame (mm)

  Conic<T> Shape() const { return Conic<T>{R, K}; }

  // z at (x, y), with dz/dx, dz/dy and (hessian != nullptr) [zxx, zxy, zyy]. Beyond an
  // ellipsoid's or sphere's equator (no real sag) the value is NaN, which the callers' checks
  // refuse.
  T Z(const T& x, const T& y, T* zx = nullptr, T* zy = nullptr, T* hessian = nullptr) const {
    using std::sqrt;
    const T r2 = x * x + y * y;
    const T one_k = T(1) + K;
    const T s = r2 / (R + sqrt(R * R - one_k * r2));
    const T g = T(1) / (R - one_k * s);
    if (zx) *zx = g * x;
    if (zy) *zy = g * y;
    if (hessian) {
      const T g3 = one_k * g * g * g;
      hessian[0] = g + g3 * x * x;
      hessian[1] = g3 * x * y;
      hessian[2] = g + g3 * y * y;
    }
    return vertex_z + s;
  }

  // Unit normal at the surface point above (p.x, p.y): +z side (into the mirror's body, away
  // from the reflective side), as HyperboloidSheet::Normal orients mirror 1's.
  Vec3<T> Normal(const Vec3<T>& p) const {
    T zx, zy;
    Z(p.x(), p.y(), &zx, &zy);
    const Vec3<T> g(-zx, -zy, T(1));
    return g / g.norm();
  }

  // Smallest t > t_min with origin + t * dir on this sheet (the branch through the vertex);
  // false if none. Solves r^2 - 2 R s + (1 + K) s^2 = 0 along the line, s = z - vertex_z.
  bool IntersectRay(const Vec3<T>& origin, const Vec3<T>& dir, T* t,
                    const T& t_min = T(1e-9)) const {
    using std::abs;
    using std::sqrt;
    const T one_k = T(1) + K;
    const T sz = origin.z() - vertex_z;
    const T qa = dir.x() * dir.x() + dir.y() * dir.y() + one_k * dir.z() * dir.z();
    const T qb = T(2) * (origin.x() * dir.x() + origin.y() * dir.y() - R * dir.z() +
                         one_k * sz * dir.z());
    const T qc = origin.x() * origin.x() + origin.y() * origin.y() - T(2) * R * sz +
                 one_k * sz * sz;
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
      const T q = qb >= T(0) ? T(-0.5) * (qb + sq) : T(-0.5) * (qb - sq);
      roots[n++] = q / qa;
      if (q != T(0)) roots[n++] = qc / q;
    }
    bool found = false;
    T best = T(0);
    for (int i = 0; i < n; ++i) {
      const T ti = roots[i];
      if (!(ti > t_min)) continue;
      const T s = sz + ti * dir.z();
      if (!(R - one_k * s > T(0))) continue;  // the other branch
      if (!found || ti < best) {
        best = ti;
        found = true;
      }
    }
    if (found) *t = best;
    return found;
  }

  // The point inside the mirror the ideal reflection seed starts from: the near focus (the
  // single viewpoint of a central hyperboloid or paraboloid camera, the sphere's centre), or
  // the centre of curvature where the conic has no focus on the axis (K > 0).
  T SeedPointZ() const {
    T s;
    if (!Shape().NearFocus(&s)) s = R;
    return vertex_z + s;
  }
};

}  // namespace omni
