// The generalised, NON-central rig model (docs/design.md, Conventions): a pinhole camera with radial-tangential
// distortion, two hyperboloidal mirror bodies each with its own misalignment cam_from_mirror_i, and
// the planar reflex disc that is part of mirror 1's body. With every misalignment zero and no
// distortion it equals IdealModel (ideal_model.h) to rounding.
//
// Forward projection exists ONCE per optical path, templated on the scalar (double, ceres::Jet),
// as free functions over the raw parameter blocks of RigParams (COLMAP style; a RigBlocks bundle
// indexed by RigBlockId, each block's coordinates named in rig_blocks.h), so that Ceres
// differentiates the very code that the rest of the program runs:
//   camera[5]        fx, fy, cx, cy, skew
//   distortion[5]    dist_k1, dist_k2, dist_p1, dist_p2, dist_k3
//   mirror1_shape[2] c1, k1            mirror2_shape[2] c2, k2
//   mirror1_pose[5]  cam_from_mirror1: rx, ry, tx, ty, tz   (mirror2_pose[5] likewise)
//   reflex[3]        the reflex plane in M1: rx, ry, dz
//   mirror1_profile[6], mirror2_profile[6]  each mirror's profile correction (mirror_profile.h),
//                    read only where RigFixed's profile shape is present (nullptr: none)
// and RigFixed (d, r_sys, r_ref, r_cam: design data never refined, the profiles' radii and
// ripple, plus solver options). Each mirror is a MirrorSurface: its conic plus its profile.
//
// A SINGLE-mirror rig (RigKind::kSingle, types.h) has mirror 1's path only: its mirror a conic of
// any kind (conic_sheet.h, shape block R, K), no reflex disc, the used annulus r_cam..r_sys, and a
// perspective or telecentric lens (for a telecentric one the eye is at infinity along the
// camera's axis and the pixel is K(distort(x, y)) of S1's lateral position in mm).
//
// Mirror 1 path (outer ring): world point P -> reflection point S1 on mirror 1 -> camera centre O.
//   S1 solves the law of reflection between P and O (reflection_solver.h) in M1's frame;
//   pixel = K(distort(x/z, y/z)) of S1 in C.
// Mirror 2 path (inner ring): P -> S2 on mirror 2 -> reflex plane at X -> O. Mirroring O in the
//   reflex plane (cam_from_mirror1 * ReflexPlaneInMirror1) gives the virtual camera V; S2 solves
//   the law of reflection between P and V in M2's frame, X is where the segment S2 -> V crosses
//   the reflex plane, and pixel = K(distort(x/z, y/z)) of X.
//
// A projection is VALID (true) only if all of these hold, and otherwise returns false (never NaN,
// never a pixel of the other ring):
//  - the reflection-point solver converged (Newton on grad L = 0, see reflection_solver.h);
//  - P lies in front of the mirror: the eye (O or V) and P are both on the reflective side of the
//    tangent plane at S (which also rules out P inside the mirror's body and P on the far side);
//  - mirror 1: r(S1) <= r_sys in M1, and S1 lies beyond the reflex plane (O and S1 on opposite
//    sides), and the camera ray O -> S1 crosses the reflex plane OUTSIDE the reflex disc
//    (|X - disc centre| > r_ref: otherwise the disc occludes S1);
//  - mirror 2: r_cam <= r(S2) <= r_sys in M2 (the hole and the rim), S2 on the camera's side of the
//    reflex plane and V behind it, and the path S2 -> V crosses the plane INSIDE the disc
//    (|X - disc centre| <= r_ref);
//  - the point the camera sees (S1, or X for mirror 2) is in front of the camera (z > 0 in C).
//  - no segment of the path crosses a post of the mount (model/mount.h), where the model has one.
// Not modelled: occlusion of a light path by the other mirror's body or the lips, vignetting by
// the hole's rim, and the range where a strong lens distortion folds over (beyond the image).
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "model/camera.h"
#include "model/hyperboloid.h"
#include "model/mount.h"
#include "model/reflection_solver.h"
#include "model/rig_frames.h"
#include "model/rig_params.h"
#include "model/types.h"

namespace omni {

// Design data that a calibration never refines (mm), and the reflection solver's options.
struct RigFixed {
  RigKind rig = RigKind::kFolded;
  LensKind lens = LensKind::kPerspective;
  double d = 0, r_sys = 0, r_ref = 0, r_cam = 0;
  double vertex_z = 0;  // a single-mirror rig's vertex height in M1 (conic_sheet.h)
  // Mirror 1: how far (mm) S1 may lie on the camera's side of the reflex plane and still count
  // as seen when it is outside the disc's radius. 0 for the model (the ideal rig's validity);
  // the calibration's corner costs use a few mm: S1 of a corner seen at the ring's inner edge
  // lies within a hair of the plane, and a hard wall there stalls the trust region (every trial
  // step that moves S1 across it fails, however short).
  double reflex_side_slack = 0;
  // Each mirror's profile shape (present false: the exact conic).
  ProfileShape profile1, profile2;
  // The mount's posts and the pose of the body they are fixed in (validity only: a path through
  // a post is invalid). The calibration's costs leave it out (a detected corner is seen).
  Mount mount;
  Pose<double> cam_from_mount;
  ReflectionSolverOptions solver;
};
RigFixed FixedOf(const RigParams& rig);

// Diagnostics of one projection (double values).
struct ProjectionInfo {
  ReflectionSolverInfo solver;
  Eigen::Vector3d point_on_mirror = Eigen::Vector3d::Zero();         // S, mirror's body frame
  Eigen::Vector3d point_on_mirror_in_cam = Eigen::Vector3d::Zero();  // S in C
  Eigen::Vector3d eye_in_mirror = Eigen::Vector3d::Zero();           // O (mirror 1) or V (mirror 2)
  Eigen::Vector3d reflex_point_in_cam = Eigen::Vector3d::Zero();     // mirror 2: X in C
};

template <typename T>
Plane<double> ScalarPart(const Plane<T>& plane) {
  return Plane<double>{ScalarPart(plane.point), ScalarPart(plane.normal)};
}

// P in front of the mirror: the eye and the point on the reflective side of the tangent plane
// at S (the sheet's normal points into the mirror's body). eye_at_infinity: `eye` is the unit
// direction towards it.
inline bool FacesReflectiveSide(const MirrorSurface<double>& sheet, const Eigen::Vector3d& s,
                                const Eigen::Vector3d& eye, const Eigen::Vector3d& point,
                                bool eye_at_infinity = false) {
  const Eigen::Vector3d normal = sheet.Normal(s);
  const Eigen::Vector3d to_eye = eye_at_infinity ? eye : Eigen::Vector3d(eye - s);
  return to_eye.dot(normal) < 0 && (point - s).dot(normal) < 0;
}

// The reflection point S on a mirror's sheet for an eye and a point (both in the mirror's body
// frame) [reflection law], in T and in double (*s_d, for the validity checks that need no
// derivatives). False if the solve fails, S lies outside r_min <= |S_xy| <= r_max (the mirror's
// hole and rim), or the eye and the point are not in front of the mirror at S. eye_at_infinity
// (a telecentric lens): `eye` is the unit direction towards the camera.
template <typename T>
bool ReflectOnSheet(const MirrorSurface<T>& sheet, const Vec3<T>& eye, const Vec3<T>& point,
                    const ReflectionSolverOptions& solver, double r_min, double r_max,
                    ProjectionInfo* info, Vec3<T>* s, Eigen::Vector3d* s_d,
                    bool eye_at_infinity = false) {
  if (!SolveReflectionPoint(sheet, eye, point, solver, s, info ? &info->solver : nullptr,
                            eye_at_infinity)) {
    return false;
  }
  *s_d = ScalarPart(*s);
  const double r2 = s_d->head<2>().squaredNorm();
  if (!(r2 >= r_min * r_min) || !(r2 <= r_max * r_max)) return false;
  return FacesReflectiveSide(ScalarPart(sheet), *s_d, ScalarPart(eye), ScalarPart(point),
                             eye_at_infinity);
}

// The geometry of the mirror-1 path built from the parameter blocks.
template <typename T>
struct Mirror1Path {
  Pinhole<T> cam;
  RadTan<T> dist;
  MirrorSurface<T> sheet;
  Pose<T> mirror_from_cam;
  Pose<T> cam_from_mirror;
  Plane<double> reflex_in_mirror;  // only decides validity (occlusion): no derivatives

  // Reads camera, distortion, mirror1_shape, mirror1_profile, mirror1_pose, reflex (a
  // single-mirror rig: not the reflex; its shape block is the conic's R, K).
  static Mirror1Path FromBlocks(const RigBlocks<T>& b, const RigFixed& fixed) {
    const T* shape = b[kShape1Block];
    Mirror1Path p{PinholeFromBlock(b[kCameraBlock]),
                  RadTanFromBlock(b[kDistortionBlock]),
                  fixed.rig == RigKind::kSingle
                      ? MirrorSurface<T>(
                            ConicSheet<T>{shape[kShapeC], shape[kShapeK], T(fixed.vertex_z)},
                            fixed.profile1, b[kProfile1Block])
                      : MirrorSurface<T>(HyperboloidSheet<T>::Mirror1(shape[kShapeC],
                                                                      shape[kShapeK]),
                                         fixed.profile1, b[kProfile1Block]),
                  Pose<T>{},
                  PoseFromBlock(b[kPose1Block]),
                  Plane<double>{}};
    if (fixed.rig == RigKind::kSingle) {
      p.mirror_from_cam = p.cam_from_mirror.Inverse();
      return p;
    }
    const T* reflex = b[kReflexBlock];
    const double reflex_d[3] = {ScalarPart(reflex[kReflexRx]), ScalarPart(reflex[kReflexRy]),
                                ScalarPart(reflex[kReflexDz])};
    p.reflex_in_mirror = ReflexPlaneInMirror1(reflex_d, fixed.d);
    p.mirror_from_cam = p.cam_from_mirror.Inverse();
    return p;
  }

  bool Project(const RigFixed& fixed, const Vec3<T>& point_in_cam, Vec2<T>* pixel,
               ProjectionInfo* info = nullptr) const {
    if (fixed.rig == RigKind::kSingle) return ProjectSingle(fixed, point_in_cam, pixel, info);
    const Vec3<T> eye = mirror_from_cam.translation;  // the camera centre in M1
    Vec3<T> s;
    Eigen::Vector3d s_d;
    if (!ReflectOnSheet(sheet, eye, mirror_from_cam * point_in_cam, fixed.solver, 0.0,
                        fixed.r_sys, info, &s, &s_d)) {
      return false;
    }
    const Eigen::Vector3d eye_d = ScalarPart(eye);
    const Plane<double>& reflex_d = reflex_in_mirror;
    const double eye_side = (eye_d - reflex_d.point).dot(reflex_d.normal);
    const double s_side = (s_d - reflex_d.point).dot(reflex_d.normal);
    if (!(eye_side > 0) || !(s_side < fixed.reflex_side_slack)) return false;
    // Where O -> S1 meets the plane (or, for S1 within the slack on the camera's side, S1's foot
    // on the plane) must be outside the disc; otherwise the disc occludes S1.
    const Eigen::Vector3d crossing =
        s_side < 0 ? Eigen::Vector3d(eye_d + eye_side / (eye_side - s_side) * (s_d - eye_d))
                   : Eigen::Vector3d(s_d - s_side * reflex_d.normal);
    if (!((crossing - reflex_d.point).squaredNorm() > fixed.r_ref * fixed.r_ref)) {
      return false;  // the reflex disc occludes S1
    }
    const Vec3<T> s_in_cam = cam_from_mirror * s;
    if (!(s_in_cam.z() > T(0))) return false;
    if (fixed.mount.present) {  // the path point -> S1 -> O through a post
      const Eigen::Vector3d s_cam_d = ScalarPart(s_in_cam);
      if (SegmentHitsMount(fixed.mount, fixed.cam_from_mount, ScalarPart(point_in_cam), s_cam_d) ||
          SegmentHitsMount(fixed.mount, fixed.cam_from_mount, s_cam_d, Eigen::Vector3d::Zero())) {
        return false;
      }
    }
    *pixel = PixelOfPointInCam(cam, dist, s_in_cam);
    if (info) {
      info->point_on_mirror = ScalarPart(s);
      info->point_on_mirror_in_cam = ScalarPart(s_in_cam);
      info->eye_in_mirror = ScalarPart(eye);
      info->reflex_point_in_cam = Eigen::Vector3d::Zero();
    }
    return true;
  }

  // A single-mirror rig (no reflex disc): the reflection between the point and the camera
  // centre (perspective) or the camera's axis direction (telecentric: the eye at infinity),
  // within the mirror's used annulus r_cam <= r <= r_sys.
  bool ProjectSingle(const RigFixed& fixed, const Vec3<T>& point_in_cam, Vec2<T>* pixel,
                     ProjectionInfo* info) const {
    const bool telecentric = fixed.lens == LensKind::kTelecentric;
    // The eye in M1: the camera centre, or the unit direction from the mirror to the camera.
    const Vec3<T> eye = telecentric ? Vec3<T>(mirror_from_cam.Rotate(Vec3<T>(T(0), T(0), T(-1))))
                                    : Vec3<T>(mirror_from_cam.translation);
    Vec3<T> s;
    Eigen::Vector3d s_d;
    if (!ReflectOnSheet(sheet, eye, mirror_from_cam * point_in_cam, fixed.solver, fixed.r_cam,
                        fixed.r_sys, info, &s, &s_d, telecentric)) {
      return false;
    }
    const Vec3<T> s_in_cam = cam_from_mirror * s;
    if (!telecentric && !(s_in_cam.z() > T(0))) return false;
    if (fixed.mount.present) {  // the path point -> S1 -> camera through a post
      const Eigen::Vector3d s_cam_d = ScalarPart(s_in_cam);
      const Eigen::Vector3d lens_d =
          telecentric ? Eigen::Vector3d(s_cam_d.x(), s_cam_d.y(), 0) : Eigen::Vector3d::Zero();
      if (SegmentHitsMount(fixed.mount, fixed.cam_from_mount, ScalarPart(point_in_cam), s_cam_d) ||
          SegmentHitsMount(fixed.mount, fixed.cam_from_mount, s_cam_d, lens_d)) {
        return false;
      }
    }
    *pixel = PixelOfPointInCam(cam, dist, s_in_cam, fixed.lens);
    if (info) {
      info->point_on_mirror = ScalarPart(s);
      info->point_on_mirror_in_cam = ScalarPart(s_in_cam);
      info->eye_in_mirror = ScalarPart(eye);
      info->reflex_point_in_cam = Eigen::Vector3d::Zero();
    }
    return true;
  }
};

// The geometry of the mirror-2 path built from the parameter blocks.
template <typename T>
struct Mirror2Path {
  Pinhole<T> cam;
  RadTan<T> dist;
  MirrorSurface<T> sheet;
  Pose<T> mirror_from_cam;
  Pose<T> cam_from_mirror;
  Plane<T> reflex_in_cam;
  Vec3<T> virtual_camera_in_cam;  // O mirrored in the reflex plane

  // Reads camera, distortion, mirror1_pose, reflex, mirror2_shape, mirror2_profile, mirror2_pose.
  static Mirror2Path FromBlocks(const RigBlocks<T>& b, const RigFixed& fixed) {
    const Plane<T> reflex_in_cam = ReflexPlaneInCam(b[kPose1Block], b[kReflexBlock], T(fixed.d));
    const T* shape = b[kShape2Block];
    Mirror2Path p{PinholeFromBlock(b[kCameraBlock]),
                  RadTanFromBlock(b[kDistortionBlock]),
                  MirrorSurface<T>(
                      HyperboloidSheet<T>::Mirror2(shape[kShapeC], shape[kShapeK], T(fixed.d)),
                      fixed.profile2, b[kProfile2Block]),
                  Pose<T>{},
                  PoseFromBlock(b[kPose2Block]),
                  reflex_in_cam,
                  MirrorPoint(reflex_in_cam, Vec3<T>(T(0), T(0), T(0)))};
    p.mirror_from_cam = p.cam_from_mirror.Inverse();
    return p;
  }

  bool Project(const RigFixed& fixed, const Vec3<T>& point_in_cam, Vec2<T>* pixel,
               ProjectionInfo* info = nullptr) const {
    const Vec3<T> eye = mirror_from_cam * virtual_camera_in_cam;
    Vec3<T> s;
    Eigen::Vector3d s_d;
    if (!ReflectOnSheet(sheet, eye, mirror_from_cam * point_in_cam, fixed.solver, fixed.r_cam,
                        fixed.r_sys, info, &s, &s_d)) {
      return false;
    }
    const Vec3<T> s_in_cam = cam_from_mirror * s;
    const Plane<double> reflex_d = ScalarPart(reflex_in_cam);
    const Eigen::Vector3d virtual_camera_d = ScalarPart(virtual_camera_in_cam);
    const double camera_side = -reflex_d.point.dot(reflex_d.normal);
    const double s_side = (ScalarPart(s_in_cam) - reflex_d.point).dot(reflex_d.normal);
    const double v_side = (virtual_camera_d - reflex_d.point).dot(reflex_d.normal);
    if (!(camera_side > 0) || !(s_side > 0) || !(v_side < 0)) return false;
    // The crossing in T: s_side / (s_side - v_side) carries derivatives.
    const T s_side_t = (s_in_cam - reflex_in_cam.point).dot(reflex_in_cam.normal);
    const T v_side_t = (virtual_camera_in_cam - reflex_in_cam.point).dot(reflex_in_cam.normal);
    const Vec3<T> crossing =
        s_in_cam + s_side_t / (s_side_t - v_side_t) * (virtual_camera_in_cam - s_in_cam);
    if (!((ScalarPart(crossing) - reflex_d.point).squaredNorm() <= fixed.r_ref * fixed.r_ref)) {
      return false;  // the path misses the reflex disc
    }
    if (!(ScalarPart(crossing.z()) > 0)) return false;
    if (fixed.mount.present) {  // the path point -> S2 -> X -> O through a post
      const Eigen::Vector3d s_cam_d = ScalarPart(s_in_cam), x_d = ScalarPart(crossing);
      if (SegmentHitsMount(fixed.mount, fixed.cam_from_mount, ScalarPart(point_in_cam), s_cam_d) ||
          SegmentHitsMount(fixed.mount, fixed.cam_from_mount, s_cam_d, x_d) ||
          SegmentHitsMount(fixed.mount, fixed.cam_from_mount, x_d, Eigen::Vector3d::Zero())) {
        return false;
      }
    }
    *pixel = PixelOfPointInCam(cam, dist, crossing);
    if (info) {
      info->point_on_mirror = ScalarPart(s);
      info->point_on_mirror_in_cam = ScalarPart(s_in_cam);
      info->eye_in_mirror = ScalarPart(eye);
      info->reflex_point_in_cam = ScalarPart(crossing);
    }
    return true;
  }
};

// Pixel of point_in_cam via mirror 1 (outer ring); false if invalid (see the file comment).
template <typename T>
bool ProjectViaMirror1(const RigBlocks<T>& blocks, const RigFixed& fixed,
                       const Vec3<T>& point_in_cam, Vec2<T>* pixel,
                       ProjectionInfo* info = nullptr) {
  return Mirror1Path<T>::FromBlocks(blocks, fixed).Project(fixed, point_in_cam, pixel, info);
}

// Pixel of point_in_cam via mirror 2 and the reflex disc (inner ring); false if invalid (always
// for a single-mirror rig).
template <typename T>
bool ProjectViaMirror2(const RigBlocks<T>& blocks, const RigFixed& fixed,
                       const Vec3<T>& point_in_cam, Vec2<T>* pixel,
                       ProjectionInfo* info = nullptr) {
  if (fixed.rig == RigKind::kSingle) return false;
  return Mirror2Path<T>::FromBlocks(blocks, fixed).Project(fixed, point_in_cam, pixel, info);
}

// A back-projected ray and the mirror (ring) it came from.
struct MirrorRay {
  Mirror mirror;
  Ray ray;  // origin: the reflection point on the mirror (C); unit direction towards the world
};

// The rig in double precision with the per-path geometry computed once. Project runs the same
// templated path code as ProjectViaMirror1/2; Unproject traces the camera ray exactly.
class RigModel {
 public:
  explicit RigModel(const RigParams& params);

  // Pixel of point_in_cam via the given mirror; nullopt where invalid (see the file comment).
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& point_in_cam, Mirror mirror,
                                         ProjectionInfo* info = nullptr) const;

  // Back projection: undistort, camera ray from O; if it crosses the reflex plane inside the
  // disc it is reflected there and must hit mirror 2 within r_cam <= r <= r_sys, otherwise it
  // must hit mirror 1 beyond the reflex plane within r <= r_sys; the ray reflected by that
  // mirror is returned. nullopt if the pixel sees neither mirror (e.g. through the hole) or the
  // undistortion fails.
  std::optional<MirrorRay> Unproject(const Eigen::Vector2d& pixel) const;

  // Whether the pixel sees a post of the mount (through a mirror, or directly beyond the
  // mirrors' rim); false without a mount.
  bool PixelSeesMount(const Eigen::Vector2d& pixel) const;

  const RigParams& params() const { return params_; }
  const RigFixed& fixed() const { return fixed_; }
  const Mirror1Path<double>& path1() const { return path1_; }
  const Mirror2Path<double>& path2() const { return path2_; }

 private:
  // Whether the camera's path (points in C, in order) or the reflected world ray crosses a post.
  bool BlockedByMount(const std::vector<Eigen::Vector3d>& camera_path, const Ray& world_ray) const;
  // The camera ray of a pixel to the mirror it meets and the reflected ray, ignoring the mount;
  // *blocked: a post stands on that path. *camera_dir (optional): the undistorted camera ray.
  std::optional<MirrorRay> Trace(const Eigen::Vector2d& pixel, bool* blocked,
                                 Eigen::Vector3d* camera_dir) const;
  // Trace for a single-mirror rig from the undistorted normalised point (telecentric: mm).
  std::optional<MirrorRay> TraceSingle(const Eigen::Vector2d& xy, bool* blocked,
                                       Eigen::Vector3d* camera_dir) const;
  RigParams params_;
  RigFixed fixed_;
  Mirror1Path<double> path1_;
  Mirror2Path<double> path2_;
};

}  // namespace omni
