// A mirror's conic of revolution in the optics convention: vertex radius of curvature R and conic
// constant K, the way lens and mirror makers specify and report a surface. Its sag s, measured
// along the axis from the vertex towards the centre of curvature at radius r, solves
//   (1 + K) s^2 - 2 R s + r^2 = 0,  s(r) = r^2 / (R + sqrt(R^2 - (1 + K) r^2))
// (the second form has no cancellation and is smooth on the axis). The family:
//   K = 0 sphere, -1 < K < 0 prolate ellipsoid, K = -1 paraboloid, K < -1 hyperboloid,
//   K > 0 oblate ellipsoid.
// Ellipsoids and spheres exist only out to r^2 <= R^2 / (1 + K) (Covers); paraboloids and
// hyperboloids at every radius.
//
// The paper's hyperboloids are given by their focal separation c and shape k ([hyperboloid],
// hyperboloid.h: (z - z0)^2 / a^2 - r^2 / b^2 = 1, a = c/2 sqrt((k-2)/k), b = c/2 sqrt(2/k)).
// One sheet of it is this conic exactly, with
//   R = b^2 / a = c / sqrt(k (k - 2)),   K = -1 - b^2 / a^2 = -k / (k - 2)
// and back k = 2 K / (1 + K), c = R sqrt(k (k - 2)) (FromFocalSeparation, ToFocalSeparation).
// Templated on the scalar so that Ceres differentiates the same code.
#pragma once

#include <cmath>

namespace omni {

enum class ConicKind { kSphere, kEllipsoid, kParaboloid, kHyperboloid, kOblateEllipsoid };

template <typename T>
struct Conic {
  T R;  // vertex radius of curvature (mm), > 0
  T K;  // conic constant

  // The paper's hyperboloid of focal separation c (mm) and shape k > 2 [hyperboloid].
  static Conic FromFocalSeparation(const T& c, const T& k) {
    using std::sqrt;
    return Conic{c / sqrt(k * (k - T(2))), -k / (k - T(2))};
  }
  // The inverse, for a hyperboloid (K < -1): false otherwise.
  bool ToFocalSeparation(T* c, T* k) const {
    using std::sqrt;
    if (!(K < T(-1)) || !(R > T(0))) return false;
    *k = T(2) * K / (T(1) + K);
    *c = R * sqrt(*k * (*k - T(2)));
    return true;
  }

  // The surface reaches radius sqrt(r2) (ellipsoids and spheres close at R / sqrt(1 + K)).
  bool Covers(const T& r2) const { return R * R - (T(1) + K) * r2 >= T(0); }

  // The sag at squared radius r2 (Covers(r2) must hold).
  T Sag(const T& r2) const {
    using std::sqrt;
    return r2 / (R + sqrt(R * R - (T(1) + K) * r2));
  }
  // ds/dr divided by r (finite on the axis: 1 / R there), at squared radius r2: from the implicit
  // form, ds/dr = r / (R - (1 + K) s).
  T SlopeOverRadius(const T& r2) const { return T(1) / (R - (T(1) + K) * Sag(r2)); }

  // The focus nearest the vertex, as a sag: R / (1 + sqrt(-K)) for K <= 0 (the paraboloid's R/2,
  // the sphere's centre). For a hyperboloid it is the focus the mirror wraps around (the
  // single viewpoint of a catadioptric camera). False for K > 0, which has no focus on the axis.
  bool NearFocus(T* s) const {
    using std::sqrt;
    if (K > T(0)) return false;
    *s = R / (T(1) + sqrt(-K));
    return true;
  }
  // The other focus, as a sag: R / (1 - sqrt(-K)): behind the vertex (negative) for a
  // hyperboloid, beyond the near one for an ellipsoid; false for a paraboloid (at infinity), a
  // sphere (both foci at the centre: NearFocus) and K > 0.
  bool FarFocus(T* s) const {
    using std::sqrt;
    if (!(K < T(0)) || K == T(-1)) return false;
    *s = R / (T(1) - sqrt(-K));
    return true;
  }
};

// What kind of surface a conic constant describes; `tolerance` is how close to 0 or -1 counts as
// a sphere or a paraboloid.
inline ConicKind KindOfConic(double K, double tolerance = 1e-9) {
  if (std::abs(K) <= tolerance) return ConicKind::kSphere;
  if (std::abs(K + 1) <= tolerance) return ConicKind::kParaboloid;
  if (K < -1) return ConicKind::kHyperboloid;
  if (K < 0) return ConicKind::kEllipsoid;
  return ConicKind::kOblateEllipsoid;
}

inline const char* ConicKindName(ConicKind kind) {
  switch (kind) {
    case ConicKind::kSphere: return "sphere";
    case ConicKind::kEllipsoid: return "ellipsoid";
    case ConicKind::kParaboloid: return "paraboloid";
    case ConicKind::kHyperboloid: return "hyperboloid";
    case ConicKind::kOblateEllipsoid: return "oblate ellipsoid";
  }
  return "";
}

}  // namespace omni
