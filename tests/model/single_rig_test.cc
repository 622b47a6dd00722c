// A single-mirror rig (RigKind::kSingle): the non-central model against independent oracles.
//  - Aligned central cameras (a perspective lens at a hyperboloid's far focus, a telecentric one
//    along a paraboloid's axis) against the unified model's closed form (central_mirror.h).
//  - Misaligned cameras of every lens and conic: Project (Fermat's principle, Newton) against
//    Unproject (a ray intersected with the conic, reflected): the ray of the projected pixel
//    passes through the point.
//  - Jets of ProjectViaMirror1 against central finite differences of the double code.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "model/central_mirror.h"
#include "model/rig_model.h"
#include "model/rig_params.h"
#include "model/single_rim.h"

namespace omni {
namespace {

// Pixel radius of the unified model for a point in C (the camera's axis the mirror's).
Eigen::Vector2d UnifiedPixel(const UnifiedParameters& u, const Eigen::Vector3d& focus,
                             const Eigen::Vector3d& point, double cx, double cy) {
  const Eigen::Vector3d v = (point - focus).normalized();
  // A ray at theta from the axis pointing at the camera (-z): cos theta = -v.z; the image
  // radius gamma sin(theta) / (xi + cos(theta)) along the point's azimuth.
  return Eigen::Vector2d(cx + u.gamma * v.x() / (u.xi - v.z()), cy + u.gamma * v.y() / (u.xi - v.z()));
}

RigParams Hyperbolic() {
  CentralMirror central;
  central.mirror = Conic<double>{20.0, -2.2};
  central.lens = LensKind::kPerspective;
  central.focal_px = 800;
  return MakeSingleRig(central.mirror, central.lens, central.CameraBelowVertexMm(), 30, 5,
                       Pinhole<double>{800, 800, 640, 480, 0}, 1280, 960);
}

RigParams Parabolic() {
  // Telecentric: fx in px per mm (a 30 mm rim over 400 px).
  return MakeSingleRig(Conic<double>{16.0, -1.0}, LensKind::kTelecentric, 60, 30, 4,
                       Pinhole<double>{13.3, 13.3, 640, 512, 0}, 1280, 1024);
}

RigParams Spherical() {
  return MakeSingleRig(Conic<double>{40.0, 0.0}, LensKind::kPerspective, 90, 25, 4,
                       Pinhole<double>{1200, 1200, 640, 480, 0}, 1280, 960);
}

// Random scene points around and below the mirror (C), 0.3-3 m away.
std::vector<Eigen::Vector3d> ScenePoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> azimuth(-M_PI, M_PI), range(300, 3000), height(-1.5, 0.4);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i) {
    const double a = azimuth(rng), r = range(rng);
    out.emplace_back(r * std::cos(a), r * std::sin(a), r * height(rng));
  }
  return out;
}

void Misalign(RigParams* rig) {
  rig->kind = ModelKind::kNoncentral;
  rig->mirror1_pose = {0.004, -0.006, 0.7, -0.4, 1.5};
  rig->distortion = {rig->lens == LensKind::kTelecentric ? 2e-5 : -0.05,
                     rig->lens == LensKind::kTelecentric ? -1e-9 : 0.01, 2e-4, -1e-4, 0};
}

TEST(SingleRig, AlignedHyperboloidIsTheUnifiedModel) {
  const RigParams rig = Hyperbolic();
  CentralMirror central{Conic<double>{20.0, -2.2}, LensKind::kPerspective, 800, 0};
  const UnifiedParameters u = *UnifiedOf(central);
  const RigModel model(rig);
  double near = 0;
  ASSERT_TRUE(central.mirror.NearFocus(&near));
  const Eigen::Vector3d focus(0, 0, rig.vertex_z + near);
  int valid = 0;
  for (const Eigen::Vector3d& p : ScenePoints(400, 1)) {
    const auto pixel = model.Project(p, Mirror::kOne);
    if (!pixel) continue;
    ++valid;
    EXPECT_LT((*pixel - UnifiedPixel(u, focus, p, 640, 480)).norm(), 1e-7);
    EXPECT_FALSE(model.Project(p, Mirror::kTwo));
  }
  EXPECT_GT(valid, 200);
}

TEST(SingleRig, TelecentricParaboloidIsTheUnifiedModel) {
  const RigParams rig = Parabolic();
  CentralMirror central{Conic<double>{16.0, -1.0}, LensKind::kTelecentric, 0, 13.3};
  const UnifiedParameters u = *UnifiedOf(central);
  EXPECT_DOUBLE_EQ(u.xi, 1.0);
  const RigModel model(rig);
  const Eigen::Vector3d focus(0, 0, rig.vertex_z + 8.0);  // R / 2
  int valid = 0;
  for (const Eigen::Vector3d& p : ScenePoints(400, 2)) {
    const auto pixel = model.Project(p, Mirror::kOne);
    if (!pixel) continue;
    ++valid;
    EXPECT_LT((*pixel - UnifiedPixel(u, focus, p, 640, 512)).norm(), 1e-7);
  }
  EXPECT_GT(valid, 200);
}

// Every valid projection's pixel unprojects to a ray through the point (to 1e-6 mm per metre),
// and pixels beyond the rim or inside r_cam see nothing.
void ExpectRoundTrip(const RigParams& rig, unsigned seed) {
  const RigModel model(rig);
  int valid = 0;
  for (const Eigen::Vector3d& p : ScenePoints(300, seed)) {
    ProjectionInfo info;
    const auto pixel = model.Project(p, Mirror::kOne, &info);
    if (!pixel) continue;
    ++valid;
    const auto ray = model.Unproject(*pixel);
    ASSERT_TRUE(ray) << p.transpose();
    EXPECT_EQ(ray->mirror, Mirror::kOne);
    const Eigen::Vector3d to_point = p - ray->ray.origin;
    const double miss = (to_point - to_point.dot(ray->ray.direction) * ray->ray.direction).norm();
    EXPECT_LT(miss, 1e-6 * to_point.norm() / 1000 + 1e-7) << p.transpose();
    EXPECT_GT(to_point.dot(ray->ray.direction), 0);
    EXPECT_LT((ray->ray.origin - info.point_on_mirror_in_cam).norm(), 1e-6);
  }
  EXPECT_GT(valid, 100);
}

TEST(SingleRig, MisalignedHyperboloidRoundTrips) {
  RigParams rig = Hyperbolic();
  Misalign(&rig);
  ExpectRoundTrip(rig, 3);
}

TEST(SingleRig, MisalignedTelecentricParaboloidRoundTrips) {
  RigParams rig = Parabolic();
  Misalign(&rig);
  ExpectRoundTrip(rig, 4);
}

TEST(SingleRig, MisalignedSphereRoundTrips) {
  RigParams rig = Spherical();
  Misalign(&rig);
  ExpectRoundTrip(rig, 5);
}

TEST(SingleRig, ProfiledEllipsoidRoundTrips) {
  RigParams rig = MakeSingleRig(Conic<double>{30.0, -0.5}, LensKind::kPerspective, 80, 25, 4,
                                Pinhole<double>{1000, 1000, 640, 480, 0}, 1280, 960);
  Misalign(&rig);
  rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
  rig.mirror1_profile = {0.004, -0.003, 0.002, 0, 0.001, -0.0005};
  ExpectRoundTrip(rig, 6);
}

// The pixels of the centre (the camera's own reflection, r < r_cam) and of beyond the rim are
// no ray.
TEST(SingleRig, CentreAndBeyondTheRimSeeNothing) {
  const RigModel model(Hyperbolic());
  EXPECT_FALSE(model.Unproject(Eigen::Vector2d(640, 480)));
  EXPECT_FALSE(model.Unproject(Eigen::Vector2d(5, 5)));
}

// A mirror reaching beyond its rim (WithMirrorReaching): the pixel of a mirror point 4 mm past the
// rim has no ray in the model as it was, and in the extended one its ray is that point's (the
// oracle: the ray's origin on the mirror, RigModel's own reflection point); a radius inside the
// rim changes nothing.
TEST(SingleRig, AMirrorReachingBeyondItsRimImagesWhatLiesThere) {
  const RigParams rig = Parabolic();
  const RigParams wider = WithMirrorReaching(rig, 36.0);
  EXPECT_EQ(wider.r_sys, 36.0);
  EXPECT_EQ(wider.lip1.r_outer, 36.0);
  EXPECT_EQ(WithMirrorReaching(rig, 25.0).r_sys, rig.r_sys);
  // Telecentric along the axis: the mirror point at radius 34 is imaged at fx * 34 from the centre.
  const Eigen::Vector2d pixel(640 + 13.3 * 34, 512);
  EXPECT_FALSE(RigModel(rig).Unproject(pixel));
  const auto ray = RigModel(wider).Unproject(pixel);
  ASSERT_TRUE(ray);
  EXPECT_NEAR(ray->ray.origin.head<2>().norm(), 34.0, 1e-6);
}

// Jets: all of mirror 1's blocks and the point, against central differences.
using Jet = ceres::Jet<double, 21>;  // point 3, camera 5, distortion 5, shape 2, pose 5, + 1 spare

template <typename T>
bool Evaluate(const RigParams& rig, const T* x, Vec2<T>* pixel) {
  RigBlocks<T> blocks;
  blocks[kCameraBlock] = x + 3;
  blocks[kDistortionBlock] = x + 8;
  blocks[kShape1Block] = x + 13;
  blocks[kPose1Block] = x + 15;
  return ProjectViaMirror1(blocks, FixedOf(rig), Vec3<T>(x[0], x[1], x[2]), pixel);
}

void ExpectJetMatchesDifferences(const RigParams& rig, const Eigen::Vector3d& point) {
  std::array<double, 20> x{};
  for (int i = 0; i < 3; ++i) x[i] = point(i);
  for (int i = 0; i < 5; ++i) x[3 + i] = rig.camera[i];
  for (int i = 0; i < 5; ++i) x[8 + i] = rig.distortion[i];
  for (int i = 0; i < 2; ++i) x[13 + i] = rig.mirror1_shape[i];
  for (int i = 0; i < 5; ++i) x[15 + i] = rig.mirror1_pose[i];
  std::array<Jet, 20> xj;
  for (int i = 0; i < 20; ++i) xj[i] = Jet(x[i], i);
  Vec2<Jet> pj;
  ASSERT_TRUE(Evaluate(rig, xj.data(), &pj));
  for (int i = 0; i < 20; ++i) {
    const double h = std::max(1e-6, 1e-6 * std::abs(x[i]));
    std::array<double, 20> plus = x, minus = x;
    plus[i] += h;
    minus[i] -= h;
    Eigen::Vector2d pp, pm;
    ASSERT_TRUE(Evaluate(rig, plus.data(), &pp));
    ASSERT_TRUE(Evaluate(rig, minus.data(), &pm));
    const Eigen::Vector2d fd = (pp - pm) / (2 * h);
    for (int k = 0; k < 2; ++k) {
      EXPECT_NEAR(pj(k).v[i], fd(k), 1e-4 * (1 + std::abs(fd(k)))) << "input " << i;
    }
  }
}

TEST(SingleRig, JetsMatchFiniteDifferences) {
  for (RigParams rig : {Hyperbolic(), Parabolic(), Spherical()}) {
    Misalign(&rig);
    ExpectJetMatchesDifferences(rig, Eigen::Vector3d(900, -400, -300));
  }
}

}  // namespace
}  // namespace omni
