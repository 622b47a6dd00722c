// Frames of a misaligned rig (docs/design.md, Conventions), templated on the scalar:
//   cam_from_mirror_i: point_in_cam = R(rx, ry, 0) * point_in_mirror_i + (tx, ty, tz);
//   the reflex plane, part of mirror 1's body: through (0, 0, d/2 + dz) in M1 with normal
//   R(rx_ref, ry_ref, 0) * (0, 0, -1).
// R(w) is the rotation of rotation vector w (Rodrigues); spin about the mirror axis is
// unobservable and so never a parameter.
#pragma once

#include <cmath>

#include "model/rig_blocks.h"
#include "model/types.h"

namespace omni {

// Rotation matrix of the rotation vector (rx, ry, 0); exact at and near zero for Jets too.
template <typename T>
Mat3<T> RotationFromTilt(const T& rx, const T& ry) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta2 = rx * rx + ry * ry;
  T s, c1;  // sin(theta)/theta and (1 - cos(theta))/theta^2
  if (theta2 > T(1e-12)) {
    const T theta = sqrt(theta2);
    s = sin(theta) / theta;
    c1 = (T(1) - cos(theta)) / theta2;
  } else {  // Taylor series, exact to double precision for theta < 1e-6
    s = T(1) - theta2 / T(6);
    c1 = T(0.5) - theta2 / T(24);
  }
  // R = I + s [w]x + c1 [w]x^2 with w = (rx, ry, 0).
  Mat3<T> R;
  R(0, 0) = T(1) - c1 * ry * ry;
  R(0, 1) = c1 * rx * ry;
  R(0, 2) = s * ry;
  R(1, 0) = c1 * rx * ry;
  R(1, 1) = T(1) - c1 * rx * rx;
  R(1, 2) = -s * rx;
  R(2, 0) = -s * ry;
  R(2, 1) = s * rx;
  R(2, 2) = T(1) - c1 * theta2;
  return R;
}

// A rigid transform point_in_to = rotation * point_in_from + translation.
template <typename T>
struct Pose {
  Mat3<T> rotation;
  Vec3<T> translation;

  Vec3<T> operator*(const Vec3<T>& p) const { return rotation * p + translation; }
  Vec3<T> Rotate(const Vec3<T>& v) const { return rotation * v; }
  Pose Inverse() const {
    Pose inv;
    inv.rotation = rotation.transpose();
    inv.translation = -(inv.rotation * translation);
    return inv;
  }
};

// cam_from_mirror from a pose block [rx, ry, tx, ty, tz].
template <typename T>
Pose<T> PoseFromBlock(const T* block) {
  return Pose<T>{RotationFromTilt(block[kRx], block[kRy]), Vec3<T>(block[kTx], block[kTy], block[kTz])};
}

// A plane through `point` with unit `normal`: {x : normal . (x - point) = 0}.
template <typename T>
struct Plane {
  Vec3<T> point;
  Vec3<T> normal;
};

// The reflex plane in mirror 1's body frame from the reflex block [rx, ry, dz].
template <typename T>
Plane<T> ReflexPlaneInMirror1(const T* reflex_block, const T& d) {
  const Mat3<T> R = RotationFromTilt(reflex_block[kReflexRx], reflex_block[kReflexRy]);
  return Plane<T>{Vec3<T>(T(0), T(0), d / T(2) + reflex_block[kReflexDz]),
                  R * Vec3<T>(T(0), T(0), T(-1))};
}

// The reflex plane in C: the disc is part of mirror 1's body (cam_from_mirror1 from its pose
// block [rx, ry, tx, ty, tz]).
template <typename T>
Plane<T> ReflexPlaneInCam(const T* mirror1_pose, const T* reflex_block, const T& d) {
  const Pose<T> cam_from_mirror1 = PoseFromBlock(mirror1_pose);
  const Plane<T> in_mirror1 = ReflexPlaneInMirror1(reflex_block, d);
  return Plane<T>{cam_from_mirror1 * in_mirror1.point, cam_from_mirror1.Rotate(in_mirror1.normal)};
}

// A point of the reflex disc's rim (radius r_ref) at angle t, in mirror 1's body frame: the
// plane's point + R(rx, ry) (r_ref cos t, r_ref sin t, 0), the disc tilted with its plane.
template <typename T>
Vec3<T> ReflexRimInMirror1(const T* reflex_block, const T& d, const T& r_ref, const T& t) {
  const Mat3<T> R = RotationFromTilt(reflex_block[kReflexRx], reflex_block[kReflexRy]);
  return ReflexPlaneInMirror1(reflex_block, d).point +
         R * Vec3<T>(r_ref * cos(t), r_ref * sin(t), T(0));
}

// The mirrors' outer foci (their viewpoints in the SVP model) in C: the ideal model's
// f1 = (0, 0, c1) and f2 = (0, 0, d - c2) (ideal_model.h) carried by each mirror's pose block.
template <typename T>
Vec3<T> Focus1InCam(const T* mirror1_pose, const T* mirror1_shape) {
  return PoseFromBlock(mirror1_pose) * Vec3<T>(T(0), T(0), mirror1_shape[kShapeC]);
}
template <typename T>
Vec3<T> Focus2InCam(const T* mirror2_pose, const T* mirror2_shape, const T& d) {
  return PoseFromBlock(mirror2_pose) * Vec3<T>(T(0), T(0), d - mirror2_shape[kShapeC]);
}

// Mirror a point in a plane.
template <typename T>
Vec3<T> MirrorPoint(const Plane<T>& plane, const Vec3<T>& p) {
  return p - T(2) * (p - plane.point).dot(plane.normal) * plane.normal;
}

}  // namespace omni
