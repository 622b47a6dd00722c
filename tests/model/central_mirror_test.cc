// The central single-mirror cameras (model/central_mirror.h) against a ray trace by the law of
// reflection on the conic's sag (model/conic.h): the unified model's pixel radius equals the
// traced one, the reflected rays meet at the near focus, and a unified fit with the rim's image
// gives back the mirror and the lens.
#include "model/central_mirror.h"

#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace omni {
namespace {

struct Traced {
  double pixel_radius = 0;
  Eigen::Vector3d point, direction;  // the mirror point and the scene ray leaving it
};

// The camera at the origin looking up +z; the mirror's vertex `vertex_z` above it, opening up.
// Perspective: the camera ray through the mirror point at radius r; telecentric: the vertical ray.
Traced Trace(const CentralMirror& camera, double vertex_z, double r) {
  const Conic<double>& conic = camera.mirror;
  const Eigen::Vector3d s(r, 0, vertex_z + conic.Sag(r * r));
  const Eigen::Vector3d normal =
      Eigen::Vector3d(-conic.SlopeOverRadius(r * r) * r, 0, 1).normalized();
  Eigen::Vector3d in;
  Traced t;
  if (camera.lens == LensKind::kPerspective) {
    in = s.normalized();
    t.pixel_radius = camera.focal_px * r / s.z();
  } else {
    in = Eigen::Vector3d::UnitZ();
    t.pixel_radius = camera.magnification * r;
  }
  t.point = s;
  t.direction = in - 2 * in.dot(normal) * normal;
  return t;
}

double UnifiedRadius(const UnifiedParameters& u, const Eigen::Vector3d& direction) {
  const double cos_t = -direction.z() / direction.norm();  // from the axis pointing at the camera
  const double sin_t = direction.head<2>().norm() / direction.norm();
  return u.gamma * sin_t / (u.xi + cos_t);
}

void ExpectCentralAndUnified(const CentralMirror& camera, double vertex_z, double rim_mm) {
  const auto unified = UnifiedOf(camera);
  ASSERT_TRUE(unified.has_value());
  double near = 0;
  ASSERT_TRUE(camera.mirror.NearFocus(&near));
  const Eigen::Vector3d focus(0, 0, vertex_z + near);
  for (double r = 0.05 * rim_mm; r <= rim_mm; r += 0.05 * rim_mm) {
    const Traced t = Trace(camera, vertex_z, r);
    // The single viewpoint: the scene ray's line passes through the near focus.
    const Eigen::Vector3d to_focus = focus - t.point;
    EXPECT_LT(to_focus.cross(t.direction.normalized()).norm(), 1e-9 * camera.mirror.R) << r;
    EXPECT_NEAR(UnifiedRadius(*unified, t.direction), t.pixel_radius, 1e-9 * t.pixel_radius) << r;
  }
}

TEST(CentralMirror, HyperboloidWithPerspectiveLensIsTheUnifiedModel) {
  for (const double K : {-1.3, -2.0, -4.5}) {
    CentralMirror camera;
    camera.mirror = Conic<double>{20, K};
    camera.focal_px = 900;
    ExpectCentralAndUnified(camera, camera.CameraBelowVertexMm(), 30);
  }
}

TEST(CentralMirror, ParaboloidWithTelecentricLensIsTheUnifiedModelWithXiOne) {
  CentralMirror camera;
  camera.lens = LensKind::kTelecentric;
  camera.mirror = Conic<double>{12, -1};
  camera.magnification = 14;  // px per mm
  EXPECT_DOUBLE_EQ(UnifiedOf(camera)->xi, 1.0);
  ExpectCentralAndUnified(camera, 50, 25);
}

TEST(CentralMirror, UnifiedFitAndRimGiveBackMirrorAndLens) {
  for (const double K : {-1.3, -2.0, -4.5}) {
    CentralMirror truth;
    truth.mirror = Conic<double>{20, K};
    truth.focal_px = 900;
    const double rim_mm = 30;
    const Traced rim = Trace(truth, truth.CameraBelowVertexMm(), rim_mm);
    std::string why;
    const auto back = CentralMirrorFromUnified(*UnifiedOf(truth), LensKind::kPerspective,
                                               rim.pixel_radius, 2 * rim_mm, &why);
    ASSERT_TRUE(back.has_value()) << why;
    EXPECT_NEAR(back->mirror.R, 20, 1e-9);
    EXPECT_NEAR(back->mirror.K, K, 1e-9);
    EXPECT_NEAR(back->focal_px, 900, 1e-7);
  }
  CentralMirror truth;
  truth.lens = LensKind::kTelecentric;
  truth.mirror = Conic<double>{12, -1};
  truth.magnification = 14;
  std::string why;
  const auto back = CentralMirrorFromUnified(*UnifiedOf(truth), LensKind::kTelecentric, 14 * 25,
                                             50, &why);
  ASSERT_TRUE(back.has_value()) << why;
  EXPECT_NEAR(back->mirror.R, 12, 1e-12);
  EXPECT_NEAR(back->magnification, 14, 1e-12);
}

TEST(CentralMirror, FitsThatAreNoSuchCameraAreRefusedWithTheReason) {
  std::string why;
  EXPECT_FALSE(CentralMirrorFromUnified({1.0, 300}, LensKind::kPerspective, 400, 60, &why));
  EXPECT_NE(why.find("hyperboloid (0 < xi < 1)"), std::string::npos) << why;
  EXPECT_FALSE(CentralMirrorFromUnified({0.6, 300}, LensKind::kTelecentric, 400, 60, &why));
  EXPECT_NE(why.find("paraboloid (xi = 1)"), std::string::npos) << why;
  CentralMirror sphere;
  sphere.mirror = Conic<double>{20, 0};
  sphere.focal_px = 900;
  EXPECT_FALSE(UnifiedOf(sphere).has_value());  // a sphere has no single viewpoint
}

}  // namespace
}  // namespace omni
