// Ties our projection maths to an independent ray tracer: small self-lit spheres rendered by
// POV-Ray through the rig; their intensity-weighted image centroids must agree with Project.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/synthetic/pov_scene.h"
#include "model/ideal_model.h"
#include "model/rig_params.h"

namespace omni {
namespace {

RigParams BigRigIdeal() {
  return MakeIdealRig(DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0}, 7.0,
                      Pinhole<double>{1450, 1450, 639.5, 479.5, 0}, 1280, 960);
}

// Intensity-weighted centroid of a window (linear 16-bit intensities, background 0).
bool Centroid(const cv::Mat& grey, const Eigen::Vector2d& around, int half, Eigen::Vector2d* c) {
  const int u0 = static_cast<int>(std::lround(around.x())), v0 = static_cast<int>(std::lround(around.y()));
  double s = 0, su = 0, sv = 0;
  for (int v = v0 - half; v <= v0 + half; ++v) {
    for (int u = u0 - half; u <= u0 + half; ++u) {
      if (u < 0 || v < 0 || u >= grey.cols || v >= grey.rows) return false;
      const double w = grey.at<float>(v, u);
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

MarkerStats RenderAndCompare(const RigParams& rig, const std::string& tag) {
  const IdealModel model = rig.Ideal();
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
  EXPECT_TRUE(synthetic::RenderScene(synthetic::PovSceneText(rig, content), png, opt, &error)) << error;
  cv::Mat img = cv::imread(png, cv::IMREAD_UNCHANGED), grey;
  EXPECT_FALSE(img.empty());
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(grey, CV_32F);
  MarkerStats stats;
  for (const auto& p : points) {
    for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
      Eigen::Vector2d px, c;
      if (!model.Project(p, m, &px)) continue;
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

}  // namespace
}  // namespace omni
