// The paper's ideal single-viewpoint (SVP) rig: the camera pinhole sits at both mirrors' outer foci,
// the mirrors are coaxial with the optical axis, the reflex plane is z = d/2 with normal (0,0,-1)
// [reflex_normal], [reflex_plane]. Closed-form forward projection [lambda_1]..[m2] and back
// projection [q1_bp]..[back_projection_function], templated on the scalar.
//
// Validity (a projection is invalid, never NaN):
//  - the point must lie outside the mirror, beyond the reflection point seen from the focus
//    (0 < lambda < 1) [external_position_constraint];
//  - the reflection point must lie on the mirror's reflective area, r_ref <= r1 <= r_sys and
//    r_cam <= r2 <= r_sys [r_limits] (equivalently [image_radial_bounds]);
//  - mirror 1: the camera ray to the reflection point must pass outside the reflex disc;
//    mirror 2: the light path must cross the plane z = d/2 inside the reflex disc.
#pragma once

#include <cmath>
#include <optional>

#include "model/camera.h"
#include "model/hyperboloid.h"
#include "model/types.h"

namespace omni {

// The primary design parameters theta = [c1, c2, k1, k2, d, r_sys]
// [vector_of_primary_design_parameters], millimetres (k unitless).
struct DesignParams {
  double c1 = 0, c2 = 0, k1 = 0, k2 = 0, d = 0, r_sys = 0;
};

template <typename T>
struct IdealModelT {
  T c1, c2, k1, k2, d, r_sys;
  T r_ref;  // radius of the reflex disc
  T r_cam;  // radius of mirror 2's central hole
  Pinhole<T> cam;

  template <typename U>
  IdealModelT<U> Cast() const {
    return IdealModelT<U>{U(c1), U(c2), U(k1), U(k2), U(d), U(r_sys), U(r_ref), U(r_cam),
                          cam.template Cast<U>()};
  }

  HyperboloidSheet<T> Mirror1() const { return HyperboloidSheet<T>::Mirror1(c1, k1); }
  HyperboloidSheet<T> Mirror2() const { return HyperboloidSheet<T>::Mirror2(c2, k2, d); }
  // Primary foci in C: f1 = (0,0,c1), f2 = (0,0,d-c2); the virtual camera f2v = (0,0,d).
  Vec3<T> Focus1() const { return Vec3<T>(T(0), T(0), c1); }
  Vec3<T> Focus2() const { return Vec3<T>(T(0), T(0), d - c2); }
  T Baseline() const {  // [baseline]
    using std::abs;
    return abs(c1 + c2 - d);
  }

  // Reflection point of point_in_cam on mirror 1: p1 = f1 + lambda_1 (p_w - f1) [lambda_1], [p1].
  bool ReflectionPoint1(const Vec3<T>& point_in_cam, Vec3<T>* p1) const {
    using std::sqrt;
    const Vec3<T> d1 = point_in_cam - Focus1();
    const T den = d1.norm() * sqrt(k1 * (k1 - T(2))) - k1 * (point_in_cam.z() - c1);
    if (!(den > T(0))) return false;
    const T lambda = c1 / den;
    if (!(lambda < T(1))) return false;  // the point is inside the mirror
    *p1 = Focus1() + lambda * d1;
    return true;
  }
  // Reflection point of point_in_cam on mirror 2 [lambda_2], [p2].
  bool ReflectionPoint2(const Vec3<T>& point_in_cam, Vec3<T>* p2) const {
    using std::sqrt;
    const Vec3<T> d2 = point_in_cam - Focus2();
    const T den = d2.norm() * sqrt(k2 * (k2 - T(2))) + k2 * (point_in_cam.z() - (d - c2));
    if (!(den > T(0))) return false;
    const T lambda = c2 / den;
    if (!(lambda < T(1))) return false;
    *p2 = Focus2() + lambda * d2;
    return true;
  }

  // Forward projection [forward_projection_function]: pixel of point_in_cam via the given mirror,
  // [m1] or [m2]; false where the projection is invalid (see the header comment).
  bool Project(const Vec3<T>& point_in_cam, Mirror mirror, Vec2<T>* pixel) const {
    using std::sqrt;
    Vec3<T> p;
    if (mirror == Mirror::kOne) {
      if (!ReflectionPoint1(point_in_cam, &p)) return false;
      const T r = sqrt(p.x() * p.x() + p.y() * p.y());
      if (r < r_ref || r > r_sys) return false;
      if (!(p.z() > T(0))) return false;
      // The camera ray must clear the reflex disc: at z = d/2 its radius must exceed r_ref.
      if (r * d / (T(2) * p.z()) < r_ref) return false;
      *pixel = cam.PixelFromNormalized(Vec2<T>(p.x() / p.z(), p.y() / p.z()));
      return true;
    }
    if (!ReflectionPoint2(point_in_cam, &p)) return false;
    const T r = sqrt(p.x() * p.x() + p.y() * p.y());
    if (r < r_cam || r > r_sys) return false;
    const T depth_in_virtual_cam = d - p.z();  // zeta_2 = 1 / (d - z2) [m2]
    if (!(depth_in_virtual_cam > T(0))) return false;
    // The path P2 -> f2v crosses the reflex plane at radius r d / (2 (d - z2)) [p_reflex].
    if (r * d / (T(2) * depth_in_virtual_cam) > r_ref) return false;
    // M_ref maps (x, y, z) to (x, y, d - z) in the virtual camera [frame_change_C_to_Cvirt].
    *pixel = cam.PixelFromNormalized(
        Vec2<T>(p.x() / depth_in_virtual_cam, p.y() / depth_in_virtual_cam));
    return true;
  }

  // The mirror whose light reaches this pixel: the camera ray hits the reflex disc (mirror 2's
  // path) when it crosses z = d/2 within r_ref, otherwise it continues to mirror 1.
  Mirror MirrorOfPixel(const Vec2<T>& pixel) const {
    using std::sqrt;
    const Vec2<T> q = cam.NormalizedFromPixel(pixel);
    return sqrt(q.squaredNorm()) * d / T(2) <= r_ref ? Mirror::kTwo : Mirror::kOne;
  }

  // Back projection of a pixel through the given mirror [q1_bp]..[bp_ray2_wrt_F2]: the reflection
  // point on the mirror and the direction v_i from the primary focus F_i towards the world.
  // False where the camera ray misses the mirror's reflective area.
  bool BackProject(const Vec2<T>& pixel, Mirror mirror, Vec3<T>* point_on_mirror,
                   Vec3<T>* dir_from_focus) const {
    using std::sqrt;
    const Vec2<T> q = cam.NormalizedFromPixel(pixel);
    const T q_norm = sqrt(q.squaredNorm() + T(1));
    if (mirror == Mirror::kOne) {
      const T den = k1 - q_norm * sqrt(k1 * (k1 - T(2)));  // [t_1]
      if (!(den > T(0))) return false;
      const T t1 = c1 / den;
      const Vec3<T> p1(t1 * q.x(), t1 * q.y(), t1);  // [ray_p1_bp]
      const T r = sqrt(p1.x() * p1.x() + p1.y() * p1.y());
      if (r < r_ref || r > r_sys) return false;
      if (r * d / (T(2) * p1.z()) < r_ref) return false;  // the reflex disc is in the way
      *point_on_mirror = p1;
      *dir_from_focus = p1 - Focus1();  // [bp_ray1_wrt_F1]
      return true;
    }
    const T den = k2 - q_norm * sqrt(k2 * (k2 - T(2)));  // [t_2]
    if (!(den > T(0))) return false;
    const T t2 = c2 / den;
    // [ray_p2_bp] with q_2v = (x_q, y_q, d - 1) [q2v_bp_wrt_C].
    const Vec3<T> p2(t2 * q.x(), t2 * q.y(), d - t2);
    const T r = sqrt(p2.x() * p2.x() + p2.y() * p2.y());
    if (r < r_cam || r > r_sys) return false;
    if (r * d / (T(2) * t2) > r_ref) return false;
    *point_on_mirror = p2;
    *dir_from_focus = p2 - Focus2();  // [bp_ray2_wrt_F2]
    return true;
  }
};

using IdealModel = IdealModelT<double>;

// Elevation and azimuth of a direction [theta1], [azimuth1] (same for mirror 2).
inline double Elevation(const Eigen::Vector3d& v) { return std::asin(v.z() / v.norm()); }
inline double Azimuth(const Eigen::Vector3d& v) { return std::atan2(v.y(), v.x()); }

// Unproject a pixel of the ideal rig: the mirror it belongs to and the ray from that mirror's
// primary focus (unit direction); nullopt outside both rings.
struct IdealRay {
  Mirror mirror;
  Ray ray;
};
std::optional<IdealRay> Unproject(const IdealModel& model, const Eigen::Vector2d& pixel);

// The ideal model of a design: r_ref from [func_r] at z = d/2, r_cam given (the hole).
IdealModel MakeIdealModel(const DesignParams& theta, double r_cam, const Pinhole<double>& cam);

}  // namespace omni
