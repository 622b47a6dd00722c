// The perspective camera of the rig (docs/design.md, Conventions): pinhole with skew and OpenCV's
// radial-tangential distortion applied to normalised coordinates before K
// [camera_intrinsic_matrix]. Pixel centres at integer coordinates.
#pragma once

#include <cmath>

#include "model/rig_blocks.h"
#include "model/types.h"

namespace omni {

template <typename T>
struct Pinhole {
  T fx, fy, cx, cy, skew;

  template <typename U>
  Pinhole<U> Cast() const {
    return Pinhole<U>{U(fx), U(fy), U(cx), U(cy), U(skew)};
  }
  // u = fx x + s y + cx, v = fy y + cy for normalised (x, y) = (X/Z, Y/Z).
  Vec2<T> PixelFromNormalized(const Vec2<T>& xy) const {
    return Vec2<T>(fx * xy.x() + skew * xy.y() + cx, fy * xy.y() + cy);
  }
  // K^-1 [q1_bp].
  Vec2<T> NormalizedFromPixel(const Vec2<T>& uv) const {
    const T y = (uv.y() - cy) / fy;
    return Vec2<T>((uv.x() - cx - skew * y) / fx, y);
  }
};

// OpenCV radial-tangential coefficients, named dist_* so they never collide with the mirror k's.
template <typename T>
struct RadTan {
  T dist_k1, dist_k2, dist_p1, dist_p2, dist_k3;

  template <typename U>
  RadTan<U> Cast() const {
    return RadTan<U>{U(dist_k1), U(dist_k2), U(dist_p1), U(dist_p2), U(dist_k3)};
  }
  bool IsZero() const {
    return dist_k1 == T(0) && dist_k2 == T(0) && dist_p1 == T(0) && dist_p2 == T(0) &&
           dist_k3 == T(0);
  }
  // Distorted normalised coordinates of ideal normalised coordinates (OpenCV's model).
  Vec2<T> Distort(const Vec2<T>& xy) const {
    const T x = xy.x(), y = xy.y();
    const T r2 = x * x + y * y;
    const T radial = T(1) + r2 * (dist_k1 + r2 * (dist_k2 + r2 * dist_k3));
    return Vec2<T>(x * radial + T(2) * dist_p1 * x * y + dist_p2 * (r2 + T(2) * x * x),
                   y * radial + dist_p1 * (r2 + T(2) * y * y) + T(2) * dist_p2 * x * y);
  }
};

// Inverts RadTan::Distort by Newton's method with the exact 2x2 Jacobian; converges to machine
// precision in a few steps for realistic lenses. Returns false if it does not converge.
bool Undistort(const RadTan<double>& dist, const Eigen::Vector2d& distorted,
               Eigen::Vector2d* undistorted);

// The camera block [fx, fy, cx, cy, skew] and the distortion block [dist_k1, dist_k2, dist_p1,
// dist_p2, dist_k3] of rig_params.h as the models above.
template <typename T>
Pinhole<T> PinholeFromBlock(const T* camera) {
  return Pinhole<T>{camera[kFx], camera[kFy], camera[kCx], camera[kCy], camera[kSkew]};
}
template <typename T>
RadTan<T> RadTanFromBlock(const T* distortion) {
  return RadTan<T>{distortion[kDistK1], distortion[kDistK2], distortion[kDistP1],
                   distortion[kDistP2], distortion[kDistK3]};
}

// The pixel of a point (or direction) in C in front of the camera (z > 0): its normalised
// coordinates distorted, then K [camera_intrinsic_matrix].
template <typename T>
Vec2<T> PixelOfPointInCam(const Pinhole<T>& cam, const RadTan<T>& dist, const Vec3<T>& p) {
  return cam.PixelFromNormalized(dist.Distort(Vec2<T>(p.x() / p.z(), p.y() / p.z())));
}

// The pixel of a point on a telecentric (orthographic) lens's side (docs/design.md, The rig):
// its lateral position (x, y) in C in mm distorted, then K (fx, fy in px per mm).
template <typename T>
Vec2<T> TelecentricPixelOfPointInCam(const Pinhole<T>& cam, const RadTan<T>& dist,
                                     const Vec3<T>& p) {
  return cam.PixelFromNormalized(dist.Distort(Vec2<T>(p.x(), p.y())));
}

// The pixel of the point the camera sees, by lens kind.
template <typename T>
Vec2<T> PixelOfPointInCam(const Pinhole<T>& cam, const RadTan<T>& dist, const Vec3<T>& p,
                          LensKind lens) {
  return lens == LensKind::kTelecentric ? TelecentricPixelOfPointInCam(cam, dist, p)
                                        : PixelOfPointInCam(cam, dist, p);
}

}  // namespace omni
