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

#include "synthetic/camera_effects.h"
#include "synthetic/scene.h"
#include "detectors/detect_image.h"
#include "model/io/model_file.h"
#include "tests/detectors/nearest_truth.h"
#include "tests/render_window.h"
#include "tests/temp_dir.h"

namespace omni::detectors {
namespace {

namespace fs = std::filesystem;

TEST(CameraImages, ChessboardsNearAndFarInBothRingsOfARealisticCamera) {
  const RigParams rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) +
                                          "/sample_configs/big_rig_real_lens.yaml");
  const RigModel model(rig);
  synthetic::Scene scene;
  scene.targets = {ChessboardSpec(4, 7, 16), ChessboardSpec(5, 6, 35), ChessboardSpec(3, 8, 90)};
  const IdealModel ideal = rig.Ideal();
  const double z_mid = 0.5 * (ideal.c1 + ideal.d - ideal.c2);
  synthetic::SceneImage image{"camera", {}};
  const double azimuth[3] = {0.4, 2.5, 4.4}, range[3] = {380, 800, 2000};
  for (int t = 0; t < 3; ++t) {
    image.placements.push_back(synthetic::PlaceFacingAxis(
        scene.targets[t], t,
        Eigen::Vector3d(range[t] * std::cos(azimuth[t]), range[t] * std::sin(azimuth[t]), z_mid)));
  }
  scene.images.push_back(image);
  const auto truth = synthetic::ComputeTruth(model, scene, image);
  const std::string dir = omni::testing::UniqueTempDir("omni_camera_detect");
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::Mat pinhole(rig.image_height, rig.image_width, CV_16UC3, cv::Scalar::all(0));
  std::string error;
  ASSERT_TRUE(omni::testing::RenderTargetWindows(rig, scene, image, truth, dir, &pinhole, &error))
      << error;
  const synthetic::CameraEffects camera = *synthetic::CameraPreset("realistic");
  std::vector<uchar> jpeg;
  ASSERT_TRUE(synthetic::EncodeCameraImage(synthetic::ApplyCamera(pinhole, rig, camera, 7), camera, &jpeg));
  const cv::Mat photo = cv::imdecode(jpeg, cv::IMREAD_UNCHANGED);
  cv::imwrite(dir + "/camera.jpg", photo);  // to look at when the test fails

  DetectorContext ctx(rig, scene.targets);
  ctx.tone = io::ToneCurve::kSrgb;
  const ImageObservations det = DetectImage(photo, &ctx);
  int visible[2] = {0, 0}, found[2] = {0, 0}, wrong = 0;
  double sum[2] = {0, 0}, worst[2] = {0, 0};
  for (const auto& c : truth) {
    for (int m = 0; m < 2; ++m) visible[m] += c.pixel[m].has_value();
  }
  for (const auto& o : det.corners) {
    const int m = MirrorIndex(o.mirror) - 1;
    double d = 0;
    const synthetic::CornerTruth* near = omni::testing::NearestTruth(truth, o.mirror, o.pixel, &d);
    if (!near || d > 3 || near->id != o.id || near->target != o.target) {
      ++wrong;
      continue;
    }
    ++found[m];
    sum[m] += d;
    worst[m] = std::max(worst[m], d);
  }
  for (int m = 0; m < 2; ++m) {
    std::printf("ring %d: %d of %d corners, mean %.3f px, max %.3f px\n", m + 1, found[m],
                visible[m], sum[m] / std::max(1, found[m]), worst[m]);
    EXPECT_GE(found[m], 0.95 * visible[m]) << "ring " << m + 1;
    // cornerSubPix alone (and its curvature correction) gave ring 2 0.090 px mean, max 0.32
    // here (ring 1 0.043 / 0.085): the demosaicing's errors along the 4-6 px squares' edges
    // turned its gradients. The blurred-junction fit (corner_refine.h): 0.029 / 0.114 (0.017 /
    // 0.041).
    EXPECT_LE(sum[m] / std::max(1, found[m]), 0.05) << "ring " << m + 1;
    EXPECT_LE(worst[m], 0.2) << "ring " << m + 1;
  }
  EXPECT_EQ(wrong, 0);
}

}  // namespace
}  // namespace omni::detectors
