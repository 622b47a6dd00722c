// A single-mirror catadioptric camera in its central (single-viewpoint) configuration, and its
// unified-model equivalent (Geyer-Daniilidis / Mei: a ray at angle theta from the axis that points
// at the camera lands at image radius gamma sin(theta) / (xi + cos(theta))). Two such cameras
// are central (Baker and Nayar):
//   perspective lens at the far focus of a hyperboloid (conic.h, K = -e^2 < -1):
//     xi = 2e / (1 + e^2),  gamma = f (e^2 - 1) / (1 + e^2),  camera R / (e - 1) below the vertex
//   telecentric (orthographic) lens along a paraboloid's axis (K = -1):
//     xi = 1,  gamma = m R  (m: the lens's magnification, px per mm)
// The unified model cannot tell the rig's scale: a rig twice the size with the camera twice as
// far gives the same image. One measured length fixes it: the mirror's rim diameter with the
// rim's radius in the image (CentralMirrorFromUnified). This is the start a calibration of a
// camera nobody designed for us refines (the camera's real offset from the focus is
// non-central: rig_model.h).
#pragma once

#include <optional>
#include <string>

#include "model/conic.h"
#include "model/types.h"

namespace omni {


struct CentralMirror {
  Conic<double> mirror;  // R (mm), K
  LensKind lens = LensKind::kPerspective;
  double focal_px = 0;          // perspective: the lens's focal length (px)
  double magnification = 0;     // telecentric: px per mm
  // Perspective: the camera's centre below the mirror's vertex along the axis (mm): the far focus.
  double CameraBelowVertexMm() const;
};

struct UnifiedParameters {
  double xi = 0, gamma = 0;  // gamma in px
};

// The unified model of a central mirror camera; nullopt if it is not central (a perspective lens
// needs K < -1, a telecentric one K = -1 within 1e-9).
std::optional<UnifiedParameters> UnifiedOf(const CentralMirror& camera);

// The central mirror camera of a unified fit, scaled by the rim: the rim of diameter
// rim_diameter_mm is seen at image radius rim_radius_px about the principal point. Perspective:
// xi in (0, 1) gives the hyperboloid's e = (1 + sqrt(1 - xi^2)) / xi, gamma the focal length, and
// the rim point's viewing angle its distance, hence R = e z - sqrt(z^2 + r^2) (z, r: the rim
// point's height above the camera and radius). Telecentric: xi = 1, m = rim radius px / mm,
// R = gamma / m. Returns nullopt with *why set if the fit cannot be such a camera.
std::optional<CentralMirror> CentralMirrorFromUnified(const UnifiedParameters& unified,
                                                      LensKind lens, double rim_radius_px,
                                                      double rim_diameter_mm, std::string* why);

}  // namespace omni
