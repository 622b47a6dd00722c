#include "model/central_mirror.h"

#include <cmath>

namespace omni {

double CentralMirror::CameraBelowVertexMm() const {
  const double e = std::sqrt(-mirror.K);
  return mirror.R / (e - 1);
}

std::optional<UnifiedParameters> UnifiedOf(const CentralMirror& camera) {
  const double K = camera.mirror.K;
  if (camera.lens == LensKind::kTelecentric) {
    if (std::abs(K + 1) > 1e-9) return std::nullopt;
    return UnifiedParameters{1.0, camera.magnification * camera.mirror.R};
  }
  if (!(K < -1)) return std::nullopt;
  const double e2 = -K, e = std::sqrt(e2);
  return UnifiedParameters{2 * e / (1 + e2), camera.focal_px * (e2 - 1) / (1 + e2)};
}

std::optional<CentralMirror> CentralMirrorFromUnified(const UnifiedParameters& unified,
                                                      LensKind lens, double rim_radius_px,
                                                      double rim_diameter_mm, std::string* why) {
  auto fail = [&](const std::string& text) {
    if (why) *why = text;
    return std::nullopt;
  };
  if (!(rim_radius_px > 0) || !(rim_diameter_mm > 0)) {
    return fail("the rim's radius in the image and its diameter must be > 0");
  }
  if (!(unified.gamma > 0)) return fail("the unified model's gamma must be > 0");
  const double r = rim_diameter_mm / 2;
  CentralMirror camera;
  camera.lens = lens;
  if (lens == LensKind::kTelecentric) {
    if (std::abs(unified.xi - 1) > 0.05) {
      return fail("a telecentric lens is central only with a paraboloid (xi = 1); the fit has xi " +
                  std::to_string(unified.xi));
    }
    camera.magnification = rim_radius_px / r;
    camera.mirror = Conic<double>{unified.gamma / camera.magnification, -1};
    return camera;
  }
  if (!(unified.xi > 0 && unified.xi < 1)) {
    return fail("a perspective lens is central only with a hyperboloid (0 < xi < 1); the fit has "
                "xi " + std::to_string(unified.xi));
  }
  const double xi = unified.xi;
  const double e = (1 + std::sqrt(1 - xi * xi)) / xi;
  const double e2 = e * e;
  camera.focal_px = unified.gamma * (1 + e2) / (e2 - 1);
  // The rim point seen at rim_radius_px lies at height z above the camera: r / z = px / f.
  const double z = r * camera.focal_px / rim_radius_px;
  // The camera sits R / (e - 1) below the vertex, so S = (r, z - R / (e - 1)) from the vertex;
  // in the conic's equation that leaves R^2 - 2 e z R + (e^2 - 1) z^2 - r^2 = 0, whose root
  // with the camera at the far (not the near) focus is R = e z - sqrt(z^2 + r^2).
  const double R = e * z - std::hypot(z, r);
  if (!(R > 0)) return fail("the rim's radius in the image does not fit the unified model");
  camera.mirror = Conic<double>{R, -e2};
  return camera;
}

}  // namespace omni
