// model/lip.h against an independent backward ray trace: the pixel a path gives for a lip point,
// traced back (undistort, camera ray, reflex plane / RigModel::Unproject), must land on that lip
// point; and the Jet derivative of a lip pixel against finite differences.
#include <gtest/gtest.h>

#include <cmath>

#include <ceres/jet.h>

#include "io/model_file.h"
#include "model/lip.h"
#include "tests/model/rig_test_util.h"

namespace omni {
namespace {

RigParams Misaligned() {
  return io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml");
}

// The camera ray of a pixel in C (unit), by undistortion.
Eigen::Vector3d CameraRay(const RigParams& rig, const Eigen::Vector2d& pixel) {
  Eigen::Vector2d xy;
  EXPECT_TRUE(Undistort(rig.Distortion(), rig.Intrinsics().NormalizedFromPixel(pixel), &xy));
  return Eigen::Vector3d(xy.x(), xy.y(), 1).normalized();
}

// Where a ray meets the lip's plane, in the owner mirror's frame.
Eigen::Vector3d HitLipPlane(const RigParams& rig, Mirror owner, const Eigen::Vector3d& origin_in_cam,
                            const Eigen::Vector3d& dir_in_cam) {
  const Pose<double> cam_from_mirror =
      PoseFromBlock(owner == Mirror::kOne ? rig.mirror1_pose.data() : rig.mirror2_pose.data());
  const Pose<double> mirror_from_cam = cam_from_mirror.Inverse();
  const Eigen::Vector3d o = mirror_from_cam * origin_in_cam, d = mirror_from_cam.Rotate(dir_in_cam);
  const double z = owner == Mirror::kOne ? rig.lip1.z : rig.lip2.z;
  return o + (z - o.z()) / d.z() * d;
}

void ExpectOnCircle(const Eigen::Vector3d& hit, double radius, double phi, double tol_mm) {
  EXPECT_NEAR(hit.head<2>().norm(), radius, tol_mm);
  EXPECT_NEAR(std::remainder(std::atan2(hit.y(), hit.x()) - phi, 2 * M_PI), 0, tol_mm / radius);
}

TEST(LipModel, DirectAndViaMirrorPathsTraceBackToTheLipPoint) {
  const RigParams rig = Misaligned();
  const RigModel model(rig);
  int checked[4] = {0, 0, 0, 0};
  for (int k = 0; k < 72; ++k) {
    const double phi = 2 * M_PI * k / 72 + 0.01;
    for (LipCircle circle : {LipCircle::kOuter}) {
      const double r = LipOf(rig, LipPath::kDirect).r_outer;
      // direct: the camera ray itself.
      const auto direct = ProjectLipPoint(model, LipPath::kDirect, circle, phi);
      ASSERT_TRUE(direct);
      ExpectOnCircle(HitLipPlane(rig, Mirror::kOne, Eigen::Vector3d::Zero(), CameraRay(rig, *direct)),
                     r, phi, 1e-6);
      ++checked[0];
      // via_mirror1 / via_mirror2: RigModel::Unproject's exact ray trace.
      for (LipPath path : {LipPath::kViaMirror1, LipPath::kViaMirror2}) {
        const auto pixel = ProjectLipPoint(model, path, circle, phi);
        if (!pixel) continue;  // mirror 2's band is hidden by the reflex rim on part of the circle
        const auto ray = model.Unproject(*pixel);
        ASSERT_TRUE(ray) << LipPathName(path) << " phi " << phi;
        EXPECT_EQ(ray->mirror, LipOwner(path));
        ExpectOnCircle(HitLipPlane(rig, LipOwner(path), ray->ray.origin, ray->ray.direction),
                       LipOf(rig, path).r_outer, phi, 1e-6);
        ++checked[path == LipPath::kViaMirror1 ? 1 : 3];
      }
    }
  }
  EXPECT_EQ(checked[0], 72);
  EXPECT_EQ(checked[1], 72);  // mirror 1 reflects its lip's outer circle all round
  EXPECT_GT(checked[3], 25);  // about 60% of the circle on this rig
}

TEST(LipModel, ViaReflexTracesBackAndRespectsTheDiscRim) {
  RigParams rig = Misaligned();
  // On the designed rig the reflex disc's rim hides the red lip entirely (its images would lie
  // beyond the rim); a wider disc shows it.
  {
    const RigModel model(rig);
    for (int k = 0; k < 36; ++k) {
      double margin = 0;
      EXPECT_FALSE(ProjectLipPoint(model, LipPath::kViaReflex, LipCircle::kOuter, k * 0.17, &margin));
      EXPECT_LT(margin, 0);
    }
  }
  rig.r_ref = 20.0;
  const RigModel model(rig);
  const Pose<double> cam_from_m1 = PoseFromBlock(rig.mirror1_pose.data());
  const Plane<double> plane_m1 = ReflexPlaneInMirror1(rig.reflex.data(), rig.d);
  const Eigen::Vector3d plane_point = cam_from_m1 * plane_m1.point;
  const Eigen::Vector3d plane_normal = cam_from_m1.Rotate(plane_m1.normal);
  int n = 0;
  for (int k = 0; k < 72; ++k) {
    const double phi = 2 * M_PI * k / 72;
    for (LipCircle circle : {LipCircle::kInner, LipCircle::kOuter}) {
      double margin = 0;
      const auto pixel = ProjectLipPoint(model, LipPath::kViaReflex, circle, phi, &margin);
      ASSERT_TRUE(pixel);
      EXPECT_GT(margin, 0);
      // Backward: camera ray -> reflex plane -> reflected ray -> lip plane.
      const Eigen::Vector3d d = CameraRay(rig, *pixel);
      const double t = plane_point.dot(plane_normal) / d.dot(plane_normal);
      const Eigen::Vector3d x = t * d;
      EXPECT_NEAR(margin, rig.r_ref - (x - plane_point).norm(), 1e-9);
      const Eigen::Vector3d reflected = Reflect(d, plane_normal);
      ExpectOnCircle(HitLipPlane(rig, Mirror::kTwo, x, reflected),
                     circle == LipCircle::kInner ? rig.lip2.r_inner : rig.lip2.r_outer, phi, 1e-6);
      ++n;
    }
  }
  EXPECT_EQ(n, 144);
}

// Whether a pixel shows mirror 2's lip in the reflex disc, by an independent backward trace:
// camera ray -> reflex plane (inside the disc) -> reflected ray -> lip plane within the annulus.
bool ShowsLip2ViaReflex(const RigParams& rig, const Eigen::Vector2d& pixel) {
  const Pose<double> cam_from_m1 = PoseFromBlock(rig.mirror1_pose.data());
  const Plane<double> plane_m1 = ReflexPlaneInMirror1(rig.reflex.data(), rig.d);
  const Eigen::Vector3d plane_point = cam_from_m1 * plane_m1.point;
  const Eigen::Vector3d plane_normal = cam_from_m1.Rotate(plane_m1.normal);
  const Eigen::Vector3d d = CameraRay(rig, pixel);
  const Eigen::Vector3d x = plane_point.dot(plane_normal) / d.dot(plane_normal) * d;
  if ((x - plane_point).norm() > rig.r_ref) return false;
  const double r = HitLipPlane(rig, Mirror::kTwo, x, Reflect(d, plane_normal)).head<2>().norm();
  return r >= rig.lip2.r_inner && r <= rig.lip2.r_outer;
}

// The band's outer edge along the image ray from the principal point through `towards`, by
// stepping outward from `start_rho` until the pixel no longer shows the lip, then bisection.
double TracedOuterEdge(const RigParams& rig, const Eigen::Vector2d& towards, double start_rho) {
  const Eigen::Vector2d pp(rig.camera[kCx], rig.camera[kCy]);
  const Eigen::Vector2d u = (towards - pp).normalized();
  double inside = start_rho;
  EXPECT_TRUE(ShowsLip2ViaReflex(rig, pp + inside * u));
  double outside = inside;
  while (ShowsLip2ViaReflex(rig, pp + outside * u)) outside += 0.25;
  for (int i = 0; i < 50; ++i) {
    const double mid = 0.5 * (inside + outside);
    (ShowsLip2ViaReflex(rig, pp + mid * u) ? inside : outside) = mid;
  }
  return 0.5 * (inside + outside);
}

// Issue #17: on a rig whose reflex disc is larger than the design's and tilted with mirror 1,
// the disc's rim, not the lip's outer circle, ends the red band seen in the disc over part of the
// azimuths. ProjectLipEdge must follow the band's true edge (traced pixel by pixel) at every
// azimuth; the plain circle image misses it by about a pixel where the rim hides it.
TEST(LipModel, ViaReflexEdgeFollowsTheDiscRimWhereItHidesTheLip) {
  const RigParams rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) +
                                          "/sample_configs/big_rig_large_reflex.yaml");
  const RigModel model(rig);
  const Eigen::Vector2d pp(rig.camera[kCx], rig.camera[kCy]);
  const RigBlocks<double> blocks = RigBlocksOf(rig);
  int on_rim = 0;
  double worst = 0, circle_miss = 0;
  for (int k = 0; k < 180; ++k) {
    const double phi = 2 * M_PI * k / 180 + 0.003;
    Eigen::Vector2d edge;
    LipBound bound;
    ASSERT_TRUE(ProjectLipEdge(blocks, model.fixed(), LipPath::kViaReflex, rig.lip2.r_outer,
                               rig.lip2.z, phi, rig.r_ref, &edge, &bound));
    const auto inner = ProjectLipPoint(model, LipPath::kViaReflex, LipCircle::kInner, phi);
    ASSERT_TRUE(inner);  // the lip's inner circle stays inside the disc all round
    const double traced = TracedOuterEdge(rig, edge, (*inner - pp).norm() + 0.5);
    worst = std::max(worst, std::abs(traced - (edge - pp).norm()));
    if (bound == LipBound::kReflexRim) {
      ++on_rim;
      // The circle's own image (margin < 0: hidden) lies beyond the traced edge.
      Eigen::Vector2d circle_px;  // no disc rim: the circle's image as if the disc were wider
      ASSERT_TRUE(ProjectLipEdge(blocks, model.fixed(), LipPath::kViaReflex, rig.lip2.r_outer,
                                 rig.lip2.z, phi, 1e9, &circle_px));
      circle_miss = std::max(circle_miss, (circle_px - pp).norm() - traced);
    }
  }
  EXPECT_LT(worst, 1e-3);                   // px
  EXPECT_GT(on_rim, 0.3 * 180);             // ~43% of the azimuths on this rig
  EXPECT_LT(on_rim, 0.6 * 180);
  EXPECT_GT(circle_miss, 1.0);              // what a residual to the circle would be off by
}

// The clipped branch's Jet derivatives (reflex tilt, mirror 1's decentre, phi) against finite
// differences: the calibration's residual moves the rim with the parameters.
TEST(LipModel, ViaReflexRimEdgeJetDerivativeMatchesFiniteDifferences) {
  using Jet = ceres::Jet<double, 3>;
  const RigParams rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) +
                                          "/sample_configs/big_rig_large_reflex.yaml");
  const RigModel model(rig);
  const double phi = M_PI;  // the rim hides the outer circle there
  auto x = testing::FlatConstants<Jet>(rig);
  x[BlockOffset(kReflexBlock) + kReflexRx].v[0] = 1;
  x[BlockOffset(kPose1Block) + kTx].v[1] = 1;
  const RigBlocks<Jet> blocks = testing::BlocksOver(x);
  Vec2<Jet> pixel;
  LipBound bound;
  ASSERT_TRUE(ProjectLipEdge(blocks, model.fixed(), LipPath::kViaReflex, Jet(rig.lip2.r_outer),
                             Jet(rig.lip2.z), Jet(phi, 2), rig.r_ref, &pixel, &bound));
  ASSERT_EQ(bound, LipBound::kReflexRim);
  const double h[3] = {1e-7, 1e-6, 1e-6};
  for (int k = 0; k < 3; ++k) {
    RigParams plus = rig, minus = rig;
    double phi_p = phi, phi_m = phi;
    if (k == 0) { plus.reflex[kReflexRx] += h[k]; minus.reflex[kReflexRx] -= h[k]; }
    if (k == 1) { plus.mirror1_pose[kTx] += h[k]; minus.mirror1_pose[kTx] -= h[k]; }
    if (k == 2) { phi_p += h[k]; phi_m -= h[k]; }
    Eigen::Vector2d a, b;
    ASSERT_TRUE(ProjectLipEdge(RigBlocksOf(plus), model.fixed(), LipPath::kViaReflex,
                               rig.lip2.r_outer, rig.lip2.z, phi_p, rig.r_ref, &a));
    ASSERT_TRUE(ProjectLipEdge(RigBlocksOf(minus), model.fixed(), LipPath::kViaReflex,
                               rig.lip2.r_outer, rig.lip2.z, phi_m, rig.r_ref, &b));
    const Eigen::Vector2d fd = (a - b) / (2 * h[k]);
    EXPECT_NEAR(pixel.x().v[k], fd.x(), 1e-5 * (1 + std::abs(fd.x()))) << k;
    EXPECT_NEAR(pixel.y().v[k], fd.y(), 1e-5 * (1 + std::abs(fd.y()))) << k;
  }
}

TEST(LipModel, JetDerivativeMatchesFiniteDifferences) {
  using Jet = ceres::Jet<double, 3>;
  const RigParams rig = Misaligned();
  const RigModel model(rig);
  for (LipPath path : {LipPath::kDirect, LipPath::kViaMirror1, LipPath::kViaMirror2}) {
    const double phi = 0.3;
    const Lip& lip = LipOf(rig, path);
    // d pixel / d (fx, cx, phi) by Jets.
    auto x = testing::FlatConstants<Jet>(rig);
    x[BlockOffset(kCameraBlock) + kFx].v[0] = 1;
    x[BlockOffset(kCameraBlock) + kCx].v[1] = 1;
    const Jet phi_jet(phi, 2);
    const RigBlocks<Jet> blocks = testing::BlocksOver(x);
    Vec2<Jet> pixel;
    ASSERT_TRUE(ProjectLipPoint(blocks, model.fixed(), path, Jet(lip.r_outer), Jet(lip.z), phi_jet, &pixel));
    // Finite differences in double.
    const double h[3] = {1e-3, 1e-3, 1e-6};
    for (int k = 0; k < 3; ++k) {
      RigParams plus = rig, minus = rig;
      double phi_p = phi, phi_m = phi;
      if (k == 0) { plus.camera[kFx] += h[k]; minus.camera[kFx] -= h[k]; }
      if (k == 1) { plus.camera[kCx] += h[k]; minus.camera[kCx] -= h[k]; }
      if (k == 2) { phi_p += h[k]; phi_m -= h[k]; }
      const auto a = ProjectLipPoint(RigModel(plus), path, LipCircle::kOuter, phi_p);
      const auto b = ProjectLipPoint(RigModel(minus), path, LipCircle::kOuter, phi_m);
      ASSERT_TRUE(a && b);
      const Eigen::Vector2d fd = (*a - *b) / (2 * h[k]);
      EXPECT_NEAR(pixel.x().v[k], fd.x(), 1e-5 * (1 + std::abs(fd.x()))) << LipPathName(path) << k;
      EXPECT_NEAR(pixel.y().v[k], fd.y(), 1e-5 * (1 + std::abs(fd.y()))) << LipPathName(path) << k;
    }
  }
}

TEST(LipModel, NamesRoundTrip) {
  for (LipPath p : {LipPath::kDirect, LipPath::kViaMirror1, LipPath::kViaReflex, LipPath::kViaMirror2}) {
    LipPath q;
    ASSERT_TRUE(ParseLipPath(LipPathName(p), &q));
    EXPECT_EQ(p, q);
  }
  LipPath q;
  EXPECT_FALSE(ParseLipPath("via_mirror3", &q));
}

TEST(LipModel, PaintsByNameAndSrgbHex) {
  EXPECT_EQ(*LipPaintRgb("blue"), Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(*LipPaintRgb("red"), Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(*LipPaintRgb("navy"), Eigen::Vector3d(0.02, 0.03, 0.12));
  for (const char* name : {"matte_red", "green", "orange", "yellow", "white", "grey", "black"}) {
    EXPECT_TRUE(LipPaintRgb(name)) << name;
  }
  // sRGB 0x80 = 128/255 is linear 0.2158605 (IEC 61966-2-1); hex digits in either case.
  EXPECT_NEAR((*LipPaintRgb("#80fF00") - Eigen::Vector3d(0.2158605, 1, 0)).norm(), 0, 1e-6);
  for (const char* bad : {"", "Blue", "navy ", "#fff", "#12345g", "80ff00", "#80ff000"}) {
    EXPECT_FALSE(LipPaintRgb(bad)) << bad;
  }
}

}  // namespace
}  // namespace omni
