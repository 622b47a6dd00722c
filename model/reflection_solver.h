// The reflection point of a light path on one hyperboloid sheet, for a NON-central rig.
//
// Given two points A (the eye: the camera centre or the virtual camera) and B (the world point) in
// the mirror's body frame, the reflection point S on the sheet satisfies the law of reflection.
// By Fermat's principle S is a stationary point of the optical path length
//   L(x, y) = |S(x, y) - A| + |S(x, y) - B|,   S(x, y) = (x, y, Z(sqrt(x^2 + y^2)))   [func_z]
// over the sheet's 2-D parameters (x, y). We solve grad L = 0 (not min L: on a concave part the
// stationary point can be a saddle or a maximum) by Newton's method with the analytic Hessian,
// safeguarded by a backtracking line search on the merit |grad L|^2 (the Newton direction is
// always a descent direction of that merit) and a cap on the step length.
//
// Derivatives for ceres::Jet (any T): the iteration runs in double on the scalar parts; then ONE
// Newton step is taken in T at the converged point, x_T = x_d - H_d^{-1} grad L_T(x_d). Since
// grad L(x_d) = 0 to rounding, the value is unchanged and the Jet carries exactly the
// implicit-function derivative dx/dtheta = -H^{-1} d(grad L)/dtheta; the iterations themselves
// are never differentiated.
#pragma once

#include <cmath>
#include <type_traits>

#include <Eigen/Core>

#include "model/hyperboloid.h"
#include "model/mirror_surface.h"
#include "model/types.h"

namespace omni {

// The double value of a scalar: itself for double, the (recursive) scalar part .a of a Jet.
inline double ScalarPart(double x) { return x; }
template <typename JetT>
double ScalarPart(const JetT& x) {
  return ScalarPart(x.a);
}
template <typename T>
Eigen::Vector3d ScalarPart(const Vec3<T>& v) {
  return Eigen::Vector3d(ScalarPart(v.x()), ScalarPart(v.y()), ScalarPart(v.z()));
}
template <typename T>
HyperboloidSheet<double> ScalarPart(const HyperboloidSheet<T>& s) {
  return HyperboloidSheet<double>{ScalarPart(s.z0), ScalarPart(s.a), ScalarPart(s.b), s.sheet};
}
template <typename T>
MirrorSurface<double> ScalarPart(const MirrorSurface<T>& s) {
  MirrorSurface<double> out;
  out.conic = ScalarPart(s.conic);
  out.general = s.general;
  out.general_conic = ConicSheet<double>{ScalarPart(s.general_conic.R),
                                         ScalarPart(s.general_conic.K),
                                         ScalarPart(s.general_conic.vertex_z)};
  out.shape = s.shape;
  for (int i = 0; i < kProfileTerms; ++i) out.coeffs[i] = ScalarPart(s.coeffs[i]);
  return out;
}

struct ReflectionSolverOptions {
  int max_iterations = 40;
  // Converged when the Newton step is shorter than this (mm). Convergence is quadratic (error
  // after such a step ~1e-11 mm) and the final Newton step in T (below) squares it again, so
  // the returned point is exact to rounding.
  double step_tolerance = 1e-5;
  // Longest Newton step (mm); longer steps are scaled down.
  double max_step = 20.0;
  // Iterates leaving the disc x^2 + y^2 <= max_radius^2 (mm) are declared diverged.
  double max_radius = 200.0;
};

struct ReflectionSolverInfo {
  int iterations = 0;         // Newton iterations in double (the final step in T not counted)
  bool converged = false;
  double gradient_norm = 0;   // |grad L| before the final Newton step (dimensionless)
};

// PathLengthGradient for an eye at infinity in the unit direction a (see there).
template <typename T>
bool PathLengthGradientToDirection(const MirrorSurface<T>& surface, const Vec3<T>& a,
                                   const Vec3<T>& b, const T& x, const T& y, Vec2<T>* grad,
                                   Eigen::Matrix<T, 2, 2>* hessian) {
  T zx, zy, zxx[3];
  const Vec3<T> s(x, y, surface.Z(x, y, &zx, &zy, hessian ? zxx : nullptr));
  const Vec3<T> sb = s - b;
  const T lb = sb.norm();
  if (!(lb > T(0))) return false;
  const T inv_lb = T(1) / lb;
  const Vec3<T> ub = sb * inv_lb;
  const Vec3<T> f = ub - a;  // dL/dS
  (*grad)(0) = f.x() + f.z() * zx;
  (*grad)(1) = f.y() + f.z() * zy;
  if (hessian) {
    Eigen::Matrix<T, 3, 2> jac;
    jac << T(1), T(0), T(0), T(1), zx, zy;
    const Mat3<T> hs = (Mat3<T>::Identity() - ub * ub.transpose()) * inv_lb;
    Eigen::Matrix<T, 2, 2> z2;
    z2 << zxx[0], zxx[1], zxx[1], zxx[2];
    *hessian = jac.transpose() * hs * jac + f.z() * z2;
  }
  return true;
}

// The point of the surface at parameters (x, y) (Jets smooth on the axis).
template <typename T>
Vec3<T> SheetPoint(const MirrorSurface<T>& surface, const T& x, const T& y) {
  return surface.Point(x, y);
}

// grad L at (x, y) and, if hessian != nullptr, its 2x2 Hessian. False if S coincides with A or B.
// An eye at infinity (a telecentric lens, a_at_infinity): `a` is the unit direction from the
// mirror towards the eye, and |S - A| becomes the path to a plane across that direction,
// L = -a.S + |S - B| (its gradient's first unit vector is -a, its Hessian term vanishes).
template <typename T>
bool PathLengthGradient(const MirrorSurface<T>& surface, const Vec3<T>& a, const Vec3<T>& b,
                        const T& x, const T& y, Vec2<T>* grad,
                        Eigen::Matrix<T, 2, 2>* hessian = nullptr, bool a_at_infinity = false) {
  if (a_at_infinity) return PathLengthGradientToDirection(surface, a, b, x, y, grad, hessian);
  T zx, zy, zxx[3];
  const Vec3<T> s(x, y, surface.Z(x, y, &zx, &zy, hessian ? zxx : nullptr));
  const Vec3<T> sa = s - a;
  const Vec3<T> sb = s - b;
  const T la = sa.norm();
  const T lb = sb.norm();
  if (!(la > T(0)) || !(lb > T(0))) return false;
  // Reciprocals once: a Jet division costs several multiplications.
  const T inv_la = T(1) / la;
  const T inv_lb = T(1) / lb;
  const Vec3<T> ua = sa * inv_la;
  const Vec3<T> ub = sb * inv_lb;
  const Vec3<T> f = ua + ub;  // dL/dS
  (*grad)(0) = f.x() + f.z() * zx;
  (*grad)(1) = f.y() + f.z() * zy;
  if (hessian) {
    // H = J^T (d2L/dS2) J + f_z d2Z/dxy2, J = dS/d(x, y) = [1 0; 0 1; zx zy],
    // d2L/dS2 = (I - ua ua^T)/la + (I - ub ub^T)/lb.
    Eigen::Matrix<T, 3, 2> jac;
    jac << T(1), T(0), T(0), T(1), zx, zy;
    const Mat3<T> hs = (Mat3<T>::Identity() - ua * ua.transpose()) * inv_la +
                       (Mat3<T>::Identity() - ub * ub.transpose()) * inv_lb;
    Eigen::Matrix<T, 2, 2> z2;
    z2 << zxx[0], zxx[1], zxx[1], zxx[2];
    *hessian = jac.transpose() * hs * jac + f.z() * z2;
  }
  return true;
}

// Newton iteration in double from the seed *xy; on success *xy is within step_tolerance of the
// stationary point (the caller takes the final step).
bool SolveReflectionPointDouble(const MirrorSurface<double>& sheet, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b, const ReflectionSolverOptions& options,
                                Eigen::Vector2d* xy, ReflectionSolverInfo* info,
                                bool a_at_infinity = false);

// The ideal (SVP) seed: where the line from the conic's primary focus to B meets the conic
// ([lambda_1], [lambda_2] written in the mirror's own frame). Exact when A is the secondary
// focus and the mirror has no profile. False if that line misses the sheet.
bool IdealReflectionSeed(const HyperboloidSheet<double>& sheet, const Eigen::Vector3d& b,
                         Eigen::Vector2d* xy);
// The same from a single-mirror rig's conic: the line from its near focus (ConicSheet::
// SeedPointZ) to B. Exact for a perspective eye at a hyperboloid's far focus and for a
// telecentric eye along a paraboloid's axis.
bool IdealReflectionSeed(const ConicSheet<double>& sheet, const Eigen::Vector3d& b,
                         Eigen::Vector2d* xy);
// The seed of either kind of surface.
inline bool IdealReflectionSeed(const MirrorSurface<double>& surface, const Eigen::Vector3d& b,
                                Eigen::Vector2d* xy) {
  return surface.general ? IdealReflectionSeed(surface.general_conic, b, xy)
                         : IdealReflectionSeed(surface.conic, b, xy);
}

// The reflection point S (mirror frame) of the path A -> S -> B on the sheet, for any scalar T;
// false if the solver did not converge. See the file comment for the derivatives. a_at_infinity:
// `a` is the unit direction towards an eye at infinity (PathLengthGradient).
template <typename T>
bool SolveReflectionPoint(const MirrorSurface<T>& sheet, const Vec3<T>& a, const Vec3<T>& b,
                          const ReflectionSolverOptions& options, Vec3<T>* point_on_mirror,
                          ReflectionSolverInfo* info = nullptr, bool a_at_infinity = false) {
  const MirrorSurface<double> sheet_d = ScalarPart(sheet);
  const Eigen::Vector3d a_d = ScalarPart(a);
  const Eigen::Vector3d b_d = ScalarPart(b);
  Eigen::Vector2d xy;
  if (!IdealReflectionSeed(sheet_d, b_d, &xy)) return false;
  ReflectionSolverInfo local_info;
  if (!info) info = &local_info;
  if (!SolveReflectionPointDouble(sheet_d, a_d, b_d, options, &xy, info, a_at_infinity)) {
    return false;
  }
  // One Newton step in T at the converged point (implicit function theorem); for T = double it
  // is the final polishing step.
  const T x0(xy.x()), y0(xy.y());
  Vec2<T> grad;
  Eigen::Matrix2d hessian;
  if constexpr (std::is_same_v<T, double>) {
    if (!PathLengthGradient(sheet, a, b, x0, y0, &grad, &hessian, a_at_infinity)) return false;
  } else {
    Eigen::Vector2d grad_d;
    if (!PathLengthGradient(sheet_d, a_d, b_d, xy.x(), xy.y(), &grad_d, &hessian,
                            a_at_infinity)) {
      return false;
    }
    if (!PathLengthGradient(sheet, a, b, x0, y0, &grad,
                            static_cast<Eigen::Matrix<T, 2, 2>*>(nullptr), a_at_infinity)) {
      return false;
    }
  }
  info->gradient_norm = ScalarPart(grad(0)) * ScalarPart(grad(0)) +
                        ScalarPart(grad(1)) * ScalarPart(grad(1));
  info->gradient_norm = std::sqrt(info->gradient_norm);
  const double det = hessian(0, 0) * hessian(1, 1) - hessian(0, 1) * hessian(1, 0);
  if (!(std::abs(det) > 0) || !std::isfinite(det)) return false;
  const double i00 = hessian(1, 1) / det, i01 = -hessian(0, 1) / det;
  const double i10 = -hessian(1, 0) / det, i11 = hessian(0, 0) / det;
  const T x = x0 - (i00 * grad(0) + i01 * grad(1));
  const T y = y0 - (i10 * grad(0) + i11 * grad(1));
  *point_on_mirror = SheetPoint(sheet, x, y);
  return true;
}

}  // namespace omni
