// Ties our projection maths to an independent ray tracer: small self-lit spheres rendered by
// POV-Ray through the rig; their intensity-weighted image centroids must agree with Project.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "model/ideal_model.h"
#include "model/rig_model.h"
#include "model/rig_params.h"
#include "synthetic/image_effects.h"
#include "synthetic/pov_scene.h"

namespace omni {
namespace {

RigParams BigRigIdeal() {
  return MakeIdealRig(DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0}, 7.0,
                      Pinhole<double>{1450, 1450, 639.5, 479.5, 0}, 1280, 960);
}

// The paper's big rig as built (sample_configs/big_rig_misaligned.yaml): decentres and tilts on
// both mirrors and the reflex disc, principal point off centre, skew, lens distortion.
RigParams BigRigMisaligned() {
  RigParams rig = BigRigIdeal();
  rig.kind = ModelKind::kNoncentral;
  rig.camera = {1452.5, 1451.0, 642.3, 476.8, 0.4};
  rig.distortion = {-0.02, 0.005, 0.0003, -0.0002, 0.0};
  rig.mirror1_pose = {0.003, -0.005, 0.3, -0.2, 0.4};
  rig.mirror2_pose = {-0.004, 0.002, -0.25, 0.35, -0.3};
  rig.reflex = {0.004, -0.003, 0.15};
  return rig;
}

// Intensity-weighted centroid of a window (linear intensities) above the window border's mean.
bool Centroid(const cv::Mat& grey, const Eigen::Vector2d& around, int half, Eigen::Vector2d* c) {
  const int u0 = static_cast<int>(std::lround(around.x())), v0 = static_cast<int>(std::lround(around.y()));
  if (u0 - half < 0 || v0 - half < 0 || u0 + half >= grey.cols || v0 + half >= grey.rows) return false;
  double border = 0;
  int n_border = 0;
  for (int k = -half; k <= half; ++k) {
    border += grey.at<float>(v0 - half, u0 + k) + grey.at<float>(v0 + half, u0 + k) +
              grey.at<float>(v0 + k, u0 - half) + grey.at<float>(v0 + k, u0 + half);
    n_border += 4;
  }
  border /= n_border;
  double s = 0, su = 0, sv = 0;
  for (int v = v0 - half; v <= v0 + half; ++v) {
    for (int u = u0 - half; u <= u0 + half; ++u) {
      const double w = std::max(0.0, grey.at<float>(v, u) - border);
      s += w;
      su += w * u;
      sv += w * v;
    }
  }
  if (s <= 0) return false;
  *c = Eigen::Vector2d(su / s, sv / s);
  return true;
}

struct MarkerStats {
  double mean = 0, max = 0;
  int n = 0;
};

// windows: POV-Ray renders only a window around each marker's predicted image (isosurfaces of
// profiled mirrors cost ~1 ms per pixel); the rig must then have no lens distortion (the
// distortion is applied to the whole rendered frame).
MarkerStats RenderAndCompare(const RigParams& rig, const std::string& tag, bool windows = false) {
  const RigModel model(rig);
  synthetic::SceneContent content;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 12; ++i) {
    const double az = i * 2 * M_PI / 12 + 0.2;
    const double range = 450 + 80 * (i % 4);
    const double z = 40 + 30 * ((i % 3) - 1);
    points.emplace_back(range * std::cos(az), range * std::sin(az), z);
    content.markers.push_back({points.back(), 0.015 * range});
  }
  const std::string dir = std::filesystem::temp_directory_path() / ("omni_markers_" + tag);
  std::filesystem::create_directories(dir);
  synthetic::RenderOptions opt;
  opt.width = rig.image_width;
  opt.height = rig.image_height;
  std::string error;
  const std::string png = dir + "/markers.png";
  const std::string pov = synthetic::PovSceneText(rig, content);
  cv::Mat grey;
  auto load = [&](const std::string& file) {
    cv::Mat img = synthetic::ApplyDistortion(cv::imread(file, cv::IMREAD_UNCHANGED), rig);
    EXPECT_FALSE(img.empty());
    cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(grey, CV_32F);
  };
  if (!windows) {
    EXPECT_TRUE(synthetic::RenderScene(pov, png, opt, &error)) << error;
    load(png);
  }
  MarkerStats stats;
  for (const auto& p : points) {
    for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
      Eigen::Vector2d c;
      const auto projected = model.Project(p, m);
      if (!projected) continue;
      const Eigen::Vector2d px = *projected;
      if (windows) {
        const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
        opt.col0 = std::max(0, u - 12), opt.col1 = std::min(rig.image_width, u + 13);
        opt.row0 = std::max(0, v - 12), opt.row1 = std::min(rig.image_height, v + 13);
        EXPECT_TRUE(synthetic::RenderScene(pov, png, opt, &error)) << error;
        load(png);
      }
      if (!Centroid(grey, px, 9, &c)) continue;
      const double e = (c - px).norm();
      std::printf("%s mirror %d predicted (%.3f, %.3f) centroid (%.3f, %.3f) error %.3f px\n",
                  tag.c_str(), MirrorIndex(m), px.x(), px.y(), c.x(), c.y(), e);
      stats.mean += e;
      stats.max = std::max(stats.max, e);
      ++stats.n;
    }
  }
  stats.mean /= std::max(1, stats.n);
  return stats;
}

TEST(PovRayMarkers, IdealRigCentroidsMatchProjection) {
  const MarkerStats s = RenderAndCompare(BigRigIdeal(), "ideal");
  std::printf("ideal rig: %d marker images, mean %.4f px, max %.4f px\n", s.n, s.mean, s.max);
  EXPECT_GE(s.n, 20);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
}

TEST(PovRayMarkers, MisalignedRigCentroidsMatchNoncentralProjection) {
  const MarkerStats s = RenderAndCompare(BigRigMisaligned(), "misaligned");
  std::printf("misaligned rig: %d marker images, mean %.4f px, max %.4f px\n", s.n, s.mean, s.max);
  EXPECT_GE(s.n, 20);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
}

}  // namespace
}  // namespace omni

namespace omni {
namespace {

// Machined mirrors (issue 40): POV-Ray draws a profiled mirror as an isosurface of the model's
// own surface; the markers' centroids must follow the profiled projection, which the exact
// quadrics' projection misses by a pixel.
TEST(PovRayMarkers, ProfiledMirrorsCentroidsMatchProfiledProjection) {
  RigParams rig = BigRigMisaligned();
  rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
  rig.profile2 = DefaultProfileShape(rig, Mirror::kTwo);
  rig.mirror1_profile = {0.006, -0.002, 0.001, 0, 0.002, 0};
  rig.mirror2_profile = {-0.005, 0.002, 0, 0, 0, 0.002};
  rig.profile1.ripple_amplitude = 0.002;
  rig.profile1.ripple_period = 6;
  rig.distortion = {0, 0, 0, 0, 0};  // windows (see RenderAndCompare)
  const MarkerStats s = RenderAndCompare(rig, "profiled", /*windows=*/true);
  std::printf("profiled rig: %d marker images, mean %.4f px, max %.4f px\n", s.n, s.mean, s.max);
  EXPECT_GE(s.n, 20);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
  // The test can fail: the same markers through the exact quadrics land far off.
  RigParams exact = rig;
  exact.profile1.present = exact.profile2.present = false;
  const RigModel with(rig), without(exact);
  double moved = 0;
  int n = 0;
  for (int i = 0; i < 12; ++i) {
    const double az = i * 2 * M_PI / 12 + 0.2, range = 450 + 80 * (i % 4), z = 40 + 30 * ((i % 3) - 1);
    const Eigen::Vector3d p(range * std::cos(az), range * std::sin(az), z);
    for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
      const auto a = with.Project(p, m), b = without.Project(p, m);
      if (a && b) moved += (*a - *b).norm(), ++n;
    }
  }
  std::printf("the profile moves the markers by %.3f px on average\n", moved / n);
  EXPECT_GT(moved / n, std::max(0.2, 5 * s.mean));
}

}  // namespace
}  // namespace omni

namespace omni {
namespace {

// The prototype's mount (issue 39): where the model says a post blocks every path to a marker
// (125 probes over its sphere's cube), POV-Ray's image shows no marker there; where it says every
// path is free, the marker is there: the centroid of its pixels above half its brightness (the
// grey post beside it, 0.25, left out) within 0.3 px of the projection.
TEST(PovRayMarkers, MountPostsHideWhatTheModelSaysTheyBlock) {
  RigParams rig = BigRigMisaligned();
  rig.distortion = {0, 0, 0, 0, 0};
  rig.mount.present = true;
  rig.mount.width = 3.0;
  rig.mount.radius = 41.5;
  rig.mount.z_min = rig.lip2.z;
  rig.mount.z_max = rig.lip1.z;
  rig.mount.azimuths = {M_PI / 2, M_PI / 2 + 2 * M_PI / 3, M_PI / 2 + 4 * M_PI / 3};
  RigParams open = rig;
  open.mount.present = false;
  const RigModel with(rig), without(open);
  synthetic::SceneContent content;
  struct Case {
    Eigen::Vector3d point;
    Mirror mirror;
    bool blocked;
    Eigen::Vector2d pixel;
  };
  std::vector<Case> cases;
  int n_blocked = 0, n_free = 0;
  for (int i = 0; i < 4000 && (n_blocked < 8 || n_free < 8); ++i) {
    const double az = rig.mount.azimuths[i % 3] + 0.003 * ((i / 3) % 41 - 20);
    const double range = 500 + 40 * (i % 7), z = -150 + 25 * (i % 13);
    const Eigen::Vector3d p(range * std::cos(az), range * std::sin(az), z);
    const double r = 0.015 * range;
    for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
      const auto px = without.Project(p, m);
      if (!px) continue;
      // Probes on a 5 x 5 x 5 grid over the sphere's bounding cube (a little larger).
      int valid = 0, probes = 0;
      for (int a = -2; a <= 2; ++a) {
        for (int b = -2; b <= 2; ++b) {
          for (int c = -2; c <= 2; ++c) {
            ++probes;
            valid += with.Project(p + 0.65 * r * Eigen::Vector3d(a, b, c), m).has_value();
          }
        }
      }
      // Markers apart in the image (their windows must not overlap).
      bool apart = true;
      for (const Case& c : cases) apart &= (c.pixel - *px).norm() > 30;
      if (!apart) continue;
      if (valid == 0 && n_blocked < 8) {
        cases.push_back({p, m, true, *px}), ++n_blocked;
      } else if (valid == probes && n_free < 8) {
        cases.push_back({p, m, false, *px}), ++n_free;
      }
    }
  }
  ASSERT_GE(n_blocked, 4);
  ASSERT_GE(n_free, 4);
  for (const Case& c : cases) content.markers.push_back({c.point, 0.015 * c.point.head<2>().norm()});
  const std::string dir = std::filesystem::temp_directory_path() / "omni_markers_mount";
  std::filesystem::create_directories(dir);
  synthetic::RenderOptions opt;
  opt.width = rig.image_width;
  opt.height = rig.image_height;
  std::string error;
  ASSERT_TRUE(synthetic::RenderScene(synthetic::PovSceneText(rig, content), dir + "/m.png", opt, &error))
      << error;
  cv::Mat img = cv::imread(dir + "/m.png", cv::IMREAD_UNCHANGED), grey;
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(grey, CV_32F, 1.0 / 255);
  for (const Case& c : cases) {
    const int u = static_cast<int>(std::lround(c.pixel.x())), v = static_cast<int>(std::lround(c.pixel.y()));
    double peak = 0;
    for (int dv = -6; dv <= 6; ++dv) {
      for (int du = -6; du <= 6; ++du) peak = std::max(peak, double(grey.at<float>(v + dv, u + du)));
    }
    // Centroid of the marker's pixels above 0.5 (the post beside it is 0.25).
    double sw = 0, su = 0, sv = 0;
    for (int dv = -9; dv <= 9; ++dv) {
      for (int du = -9; du <= 9; ++du) {
        const double w = std::max(0.0, double(grey.at<float>(v + dv, u + du)) - 0.5);
        sw += w, su += w * (u + du), sv += w * (v + dv);
      }
    }
    const bool found = sw > 0;
    const Eigen::Vector2d centroid = found ? Eigen::Vector2d(su / sw, sv / sw) : c.pixel;
    std::printf("mount: mirror %d %s at (%.1f, %.1f): peak %.2f%s\n", MirrorIndex(c.mirror),
                c.blocked ? "blocked" : "free", c.pixel.x(), c.pixel.y(), peak,
                found && !c.blocked ? (" centroid error " + std::to_string((centroid - c.pixel).norm()) + " px").c_str() : "");
    if (c.blocked) {
      EXPECT_LT(peak, 0.5) << "a marker the model says a post hides is seen";
    } else {
      EXPECT_GT(peak, 0.5);
      ASSERT_TRUE(found);
      EXPECT_LT((centroid - c.pixel).norm(), 0.3);
    }
  }
}

}  // namespace
}  // namespace omni
