// The coloured lips (docs/design.md, Conventions) as 3D circles and the optical paths by which the camera sees
// them. A lip is a flat annulus r_inner <= r <= r_outer at height z in its mirror's body frame
// (RigParams::lip1 / lip2); its two boundary circles are what an image edge can be the image of.
//
// Four optical paths form the coloured bands of the image:
//   direct      blue lip (mirror 1) seen straight by the camera: pinhole + distortion of a point in C;
//   via_mirror1 mirror 1 reflecting the underside of its own (blue) lip: ProjectViaMirror1;
//   via_reflex  red lip (mirror 2) seen in the reflex disc: the point mirrored in the reflex plane,
//               then pinhole + distortion; valid only where the camera ray meets the disc;
//   via_mirror2 mirror 2 reflecting its own (red) lip, then the reflex disc: ProjectViaMirror2.
// The two via_mirror paths are RigModel's own (rig_model.h): their maths is not repeated here.
// Everything is templated on the scalar over the raw parameter blocks of rig_params.h, so the
// calibration's Ceres residuals differentiate the same code.
//
// Not modelled: occlusion of a path by the other mirror's body (none at the lips' radii on the
// designed rigs) and vignetting by mirror 2's hole.
#pragma once

#include <cmath>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "model/camera.h"
#include "model/observations.h"
#include "model/rig_frames.h"
#include "model/rig_model.h"
#include "model/rig_params.h"
#include "model/types.h"

namespace omni {

// A lip's paint (`mirror*.lip.color` in model files) as linear RGB reflectance, 0..1: what the
// renderer paints the lip with (lit by the room) and what the detector looks for. Names:
//   blue, red        pure primaries (the paper's rig and the renders before paints were named);
//   navy, matte_red, green, orange, yellow, white, grey, black: paints as a real rig has them
//                    (navy <0.02, 0.03, 0.12>: dark and of low chroma);
//   "#rrggbb"        sRGB hex as a colour picker gives it (quote it in YAML: # starts a comment).
// nullopt for anything else.
std::optional<Eigen::Vector3d> LipPaintRgb(const std::string& color);
// The paint of mirror 1's (owner kOne) or mirror 2's lip; blue / red where its colour is not a
// paint (rigs built in code; model files are checked when read).
Eigen::Vector3d LipPaintOf(const std::string& color, Mirror owner);
// The accepted values, for error messages: "blue, red, navy, ..., or \"#rrggbb\" (sRGB)".
std::string LipPaintChoices();

// The point at azimuth phi (about the mirror's axis, from its x axis) on the circle of the given
// radius at height lip_z in the mirror's body frame, in C: cam_from_mirror * (r cos, r sin, z).
template <typename T>
Vec3<T> LipPointInCam(const T* mirror_pose, const T& radius, const T& lip_z, const T& phi) {
  using std::cos;
  using std::sin;
  return PoseFromBlock(mirror_pose) * Vec3<T>(radius * cos(phi), radius * sin(phi), lip_z);
}

// The `direct` path: pixel of a point in C seen straight by the camera (through its lens, by
// kind: a telecentric lens images (x, y) in mm). Valid if the point is in
// front of the camera and the camera ray does not pass through the reflex disc (the disc's back
// hides what lies beyond it).
template <typename T>
bool ProjectLipDirect(const RigBlocks<T>& b, const RigFixed& fixed, const Vec3<T>& point_in_cam,
                      Vec2<T>* pixel) {
  if (!(ScalarPart(point_in_cam.z()) > 0)) return false;
  // The reflex plane in C in double: validity only.
  double pose_d[5], reflex_d[3];
  for (int i = 0; i < 5; ++i) pose_d[i] = ScalarPart(b[kPose1Block][i]);
  for (int i = 0; i < 3; ++i) reflex_d[i] = ScalarPart(b[kReflexBlock][i]);
  const Plane<double> plane_in_cam = ReflexPlaneInCam(pose_d, reflex_d, fixed.d);
  const Eigen::Vector3d plane_point = plane_in_cam.point;
  const Eigen::Vector3d plane_normal = plane_in_cam.normal;
  const Eigen::Vector3d p = ScalarPart(point_in_cam);
  const double camera_side = -plane_point.dot(plane_normal);
  const double point_side = (p - plane_point).dot(plane_normal);
  if (camera_side > 0 && point_side < 0) {  // the ray crosses the plane: not inside the disc
    const Eigen::Vector3d crossing = camera_side / (camera_side - point_side) * p;
    if ((crossing - plane_point).squaredNorm() <= fixed.r_ref * fixed.r_ref) return false;
  }
  *pixel = PixelOfPointInCam(PinholeFromBlock(b[kCameraBlock]),
                             RadTanFromBlock(b[kDistortionBlock]), point_in_cam, fixed.lens);
  return true;
}

// The `via_reflex` path: pixel of a point in C seen in the reflex disc (a plane mirror): the
// camera sees the point's mirror image in the reflex plane. Valid if the point and the camera are
// on the reflective side (the camera's side) of the plane and the camera ray to the mirror image
// crosses the plane inside the disc. *disc_margin_mm (optional) receives r_ref minus the
// crossing's distance from the disc centre: how far inside the disc's rim the path runs (negative
// where the rim hides the point; then the function returns false).
template <typename T>
bool ProjectLipViaReflex(const RigBlocks<T>& b, const RigFixed& fixed, const Vec3<T>& point_in_cam,
                         Vec2<T>* pixel, double* disc_margin_mm = nullptr) {
  const Plane<T> plane = ReflexPlaneInCam(b[kPose1Block], b[kReflexBlock], T(fixed.d));
  const T camera_side = -plane.point.dot(plane.normal);
  const T point_side = (point_in_cam - plane.point).dot(plane.normal);
  if (!(ScalarPart(camera_side) > 0) || !(ScalarPart(point_side) > 0)) return false;
  const Vec3<T> image_in_cam = MirrorPoint(plane, point_in_cam);
  if (!(ScalarPart(image_in_cam.z()) > 0)) return false;
  // The camera ray O -> image crosses the plane where the light is reflected.
  const T image_side = (image_in_cam - plane.point).dot(plane.normal);
  const Eigen::Vector3d crossing =
      ScalarPart(Vec3<T>(camera_side / (camera_side - image_side) * image_in_cam));
  const double margin = fixed.r_ref - (crossing - ScalarPart(plane.point)).norm();
  if (disc_margin_mm) *disc_margin_mm = margin;
  if (!(margin >= 0)) return false;
  *pixel = PixelOfPointInCam(PinholeFromBlock(b[kCameraBlock]),
                             RadTanFromBlock(b[kDistortionBlock]), image_in_cam);
  return true;
}

// Pixel of the point at azimuth phi on a lip circle along a path; the lip is the path's owner's
// (LipOwner) with the given radius and height in its mirror frame. False where the path is
// invalid (see each path above and rig_model.h for the via_mirror paths).
template <typename T>
bool ProjectLipPoint(const RigBlocks<T>& b, const RigFixed& fixed, LipPath path, const T& radius,
                     const T& lip_z, const T& phi, Vec2<T>* pixel,
                     double* disc_margin_mm = nullptr) {
  const T* owner_pose = b[PoseBlock(LipOwner(path))];
  const Vec3<T> point_in_cam = LipPointInCam(owner_pose, radius, lip_z, phi);
  switch (path) {
    case LipPath::kDirect:
      return ProjectLipDirect(b, fixed, point_in_cam, pixel);
    case LipPath::kViaMirror1:
      return ProjectViaMirror1(b, fixed, point_in_cam, pixel);
    case LipPath::kViaReflex:
      return ProjectLipViaReflex(b, fixed, point_in_cam, pixel, disc_margin_mm);
    case LipPath::kViaMirror2:
      return ProjectViaMirror2(b, fixed, point_in_cam, pixel);
  }
  return false;
}

// What bounds a lip band at an edge point (ProjectLipEdge).
enum class LipBound { kCircle, kReflexRim };

// The band edge a lip circle gives along a path, with the occlusion followed: the
// image of the point at azimuth phi on the circle (ProjectLipPoint) where the path sees it, and
// where the reflex disc's rim hides it (via_reflex: the camera ray to the point's mirror image
// crosses the reflex plane more than disc_radius_mm from the disc's centre) the image of the rim
// point on the way there: the crossing moved radially onto the rim, seen directly. That is where
// the band (the lip seen in the disc) ends at that azimuth, and the curve is continuous where the
// rim starts to hide the circle, so a solver may move the parameters across the switch; which
// curve bounds the band is decided anew at every evaluation. On a disc larger than the design's
// and tilted, the rim hides the red lip's outer circle over ~43% of the azimuths (1.4 px off).
// Other paths: as ProjectLipPoint (on the designed rigs no occluder clips their bands: the direct
// path crosses the disc's plane ~14 mm outside it, the via_mirror paths' lip images lie well
// inside their rings). disc_radius_mm <= 0: no clipping. *bound (optional) says which curve.
template <typename T>
bool ProjectLipEdge(const RigBlocks<T>& b, const RigFixed& fixed, LipPath path, const T& radius,
                    const T& lip_z, const T& phi, double disc_radius_mm, Vec2<T>* pixel,
                    LipBound* bound = nullptr) {
  if (bound) *bound = LipBound::kCircle;
  if (path != LipPath::kViaReflex || !(disc_radius_mm > 0)) {
    return ProjectLipPoint(b, fixed, path, radius, lip_z, phi, pixel);
  }
  const Vec3<T> point_in_cam = LipPointInCam(b[kPose2Block], radius, lip_z, phi);
  const Plane<T> plane = ReflexPlaneInCam(b[kPose1Block], b[kReflexBlock], T(fixed.d));
  const T camera_side = -plane.point.dot(plane.normal);
  const T point_side = (point_in_cam - plane.point).dot(plane.normal);
  if (!(ScalarPart(camera_side) > 0) || !(ScalarPart(point_side) > 0)) return false;
  const Vec3<T> image_in_cam = MirrorPoint(plane, point_in_cam);
  const T image_side = (image_in_cam - plane.point).dot(plane.normal);
  // Where the camera ray to the mirror image crosses the plane (reflects off the disc).
  Vec3<T> crossing = camera_side / (camera_side - image_side) * image_in_cam;
  const Vec3<T> from_centre = crossing - plane.point;
  using std::sqrt;
  const T distance = sqrt(from_centre.squaredNorm());
  if (ScalarPart(distance) > disc_radius_mm) {
    crossing = plane.point + from_centre * (T(disc_radius_mm) / distance);
    if (bound) *bound = LipBound::kReflexRim;
  }
  if (!(ScalarPart(crossing.z()) > 0)) return false;
  *pixel = PixelOfPointInCam(PinholeFromBlock(b[kCameraBlock]), RadTanFromBlock(b[kDistortionBlock]),
                             crossing);
  return true;
}

// The residual of one lip edge point observed at `observed`, as the image of the band edge at
// azimuth phi (ProjectLipEdge) minus the observation; false where the path does not see the
// point. The one lip residual: the calibration's (calib/lip_cost.h, every block free) and the
// lip-only intrinsics' (detectors/lips/lip_intrinsics.cc, f and the principal point free).
template <typename T>
bool LipEdgeResidual(const RigBlocks<T>& b, const RigFixed& fixed, LipPath path, const T& radius,
                     const T& lip_z, const T& phi, double disc_radius_mm,
                     const Eigen::Vector2d& observed, T* residual) {
  Vec2<T> pixel;
  if (!ProjectLipEdge(b, fixed, path, radius, lip_z, phi, disc_radius_mm, &pixel)) return false;
  residual[0] = pixel.x() - T(observed.x());
  residual[1] = pixel.y() - T(observed.y());
  return true;
}

// The lip (RigParams::lip1 or lip2) a path images.
const Lip& LipOf(const RigParams& rig, LipPath path);

// Double convenience over a rig: pixel of the point at azimuth phi on the circle of the path's
// lip; nullopt where invalid.
std::optional<Eigen::Vector2d> ProjectLipPoint(const RigModel& model, LipPath path,
                                               LipCircle circle, double phi,
                                               double* disc_margin_mm = nullptr);

// Distance of a pixel to the image of a lip circle along a path: to the nearest point of the
// circle's image, found by a coarse-to-fine scan of the azimuth from the pixel's own about the
// principal point (a ground-truth measure for tests and evaluations; ~0.3 ms). *nearest receives
// that point. Where the path images no point of the circle near the pixel's azimuth: 1e9.
double DistanceToLipCircleImage(const RigModel& model, LipPath path, LipCircle circle,
                                const Eigen::Vector2d& pixel, Eigen::Vector2d* nearest = nullptr);

// The same for the band edge of ProjectLipEdge with the model's own disc radius (the occlusion
// followed). *bound (optional) says which curve bounds the band at the nearest point, *phi the
// circle's azimuth there.
double DistanceToLipEdgeImage(const RigModel& model, LipPath path, LipCircle circle,
                              const Eigen::Vector2d& pixel, Eigen::Vector2d* nearest = nullptr,
                              LipBound* bound = nullptr, double* phi = nullptr);

}  // namespace omni
