// Detection on what a colour camera delivers (issue #16): POV-Ray windows of a user-shaped
// placement (a small chessboard near the rig, a mid-range and a far one, big_rig_real_lens) taken
// through the realistic camera preset (defocus 0.6 / 0.9 px, vignetting, RGGB + edge-aware
// demosaic, shot and read noise, sRGB, JPEG 92), decoded as the session says (tone: srgb), and
// scored against the exact truth. The inner ring's views of such images are ~2.2 view px
// blurred; with a saddle threshold for sharp renders it lost every chessboard (0 of 82 here).
// The corners must be accurate too, above all the inner ring's small squares (corner_refine.h
// FitBlurredJunction).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "detectors/detect_image.h"
#include "io/model_file.h"
#include "synthetic/camera_effects.h"
#include "synthetic/scene.h"
#include "tests/render_window.h"
#include "tests/temp_dir.h"

namespace omni::detectors {
namespace {

namespace fs = std::filesystem;

struct RingScore {
  int visible[2] = {0, 0}, found[2] = {0, 0}, wrong = 0;
  double sum[2] = {0, 0}, worst[2] = {0, 0};
};

// One image of `targets` placed facing the axis at (azimuth, range) at mid-stereo height,
// rendered in POV-Ray windows, through the camera preset, detected from the true model and
// scored against the exact truth.
RingScore DetectThroughCamera(const std::string& preset, const std::vector<TargetSpec>& targets,
                              const std::vector<double>& azimuth, const std::vector<double>& range,
                              const std::string& name) {
  RingScore score;
  const RigParams rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) +
                                          "/sample_configs/big_rig_real_lens.yaml");
  const RigModel model(rig);
  synthetic::Scene scene;
  scene.targets = targets;
  const IdealModel ideal = rig.Ideal();
  const double z_mid = 0.5 * (ideal.c1 + ideal.d - ideal.c2);
  synthetic::SceneImage image{"camera", {}};
  for (size_t t = 0; t < targets.size(); ++t) {
    image.placements.push_back(synthetic::PlaceFacingAxis(
        scene.targets[t], static_cast<int>(t),
        Eigen::Vector3d(range[t] * std::cos(azimuth[t]), range[t] * std::sin(azimuth[t]), z_mid)));
  }
  scene.images.push_back(image);
  const auto truth = synthetic::ComputeTruth(model, scene, image);
  const std::string dir = omni::testing::UniqueTempDir(name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::Mat pinhole(rig.image_height, rig.image_width, CV_16UC3, cv::Scalar::all(0));
  std::string error;
  EXPECT_TRUE(omni::testing::RenderTargetWindows(rig, scene, image, truth, dir, &pinhole, &error))
      << error;
  const synthetic::CameraEffects camera = *synthetic::CameraPreset(preset);
  std::vector<uchar> jpeg;
  EXPECT_TRUE(synthetic::EncodeCameraImage(synthetic::ApplyCamera(pinhole, rig, camera, 7), camera, &jpeg));
  const cv::Mat photo = cv::imdecode(jpeg, cv::IMREAD_UNCHANGED);
  cv::imwrite(dir + "/camera.jpg", photo);  // to look at when the test fails

  DetectorContext ctx(rig, scene.targets);
  ctx.tone = io::ToneCurve::kSrgb;
  const ImageObservations det = DetectImage(photo, &ctx);
  for (const auto& c : truth) {
    for (int m = 0; m < 2; ++m) score.visible[m] += c.pixel[m].has_value();
  }
  for (const auto& o : det.corners) {
    const int m = MirrorIndex(o.mirror) - 1;
    const TrueCornerMatch match = NearestTrueCorner(truth, o.mirror, o.pixel);
    const double d = match.distance_px;
    const TruthCorner* near = match.corner;
    if (!near || d > 3 || near->id != o.id || near->target != o.target) {
      ++score.wrong;
      continue;
    }
    ++score.found[m];
    score.sum[m] += d;
    score.worst[m] = std::max(score.worst[m], d);
  }
  for (int m = 0; m < 2; ++m) {
    std::printf("%s ring %d: %d of %d corners, mean %.3f px, max %.3f px\n", preset.c_str(), m + 1,
                score.found[m], score.visible[m], score.sum[m] / std::max(1, score.found[m]),
                score.worst[m]);
  }
  return score;
}

TEST(CameraImages, ChessboardsNearAndFarInBothRingsOfARealisticCamera) {
  const RingScore s = DetectThroughCamera(
      "realistic", {ChessboardSpec(4, 7, 16), ChessboardSpec(5, 6, 35), ChessboardSpec(3, 8, 90)},
      {0.4, 2.5, 4.4}, {380, 800, 2000}, "omni_camera_detect");
  for (int m = 0; m < 2; ++m) {
    EXPECT_GE(s.found[m], 0.95 * s.visible[m]) << "ring " << m + 1;
    // cornerSubPix alone (and its curvature correction) gave ring 2 0.090 px mean, max 0.32
    // here (ring 1 0.043 / 0.085): the demosaicing's errors along the 4-6 px squares' edges
    // turned its gradients. The blurred-junction fit (corner_refine.h): 0.029 / 0.114 (0.017 /
    // 0.041).
    EXPECT_LE(s.sum[m] / std::max(1, s.found[m]), 0.05) << "ring " << m + 1;
    EXPECT_LE(s.worst[m], 0.2) << "ring " << m + 1;
  }
  EXPECT_EQ(s.wrong, 0);
}

// The harsh preset (exposure 0.6, vignetting 0.45, more noise, JPEG 75) darkens boards towards
// the image's corners: a third of a near board's junctions fall under the saddle threshold,
// and the region was not searched for its pattern (fewer saddles than the pattern has corners)
// although the rest formed a grid the pattern holds.
TEST(CameraImages, NearBoardsOfAHarshCameraAreFoundWhole) {
  const RingScore s = DetectThroughCamera(
      "harsh", {ChessboardSpec(5, 6, 35), ChessboardSpec(4, 7, 30), ChessboardSpec(6, 8, 25)},
      {0.5, 2.6, 4.6}, {550, 500, 600}, "omni_camera_detect_harsh");
  for (int m = 0; m < 2; ++m) {
    EXPECT_GE(s.found[m], 0.95 * s.visible[m]) << "ring " << m + 1;
    EXPECT_LE(s.sum[m] / std::max(1, s.found[m]), 0.08) << "ring " << m + 1;
  }
  EXPECT_EQ(s.wrong, 0);
}

}  // namespace
}  // namespace omni::detectors
