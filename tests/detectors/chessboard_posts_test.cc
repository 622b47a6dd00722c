// Chessboards that the rig's own parts cut, on POV-Ray renders of the paper's prototype
// (big_rig_prototype.yaml: three 3 mm posts at 41.5 mm, azimuths 90 / 210 / 330 deg in mirror
// 1's body) at 640x512, through DetectImage: a board crossed by a post, and one cut by the inner
// ring's edge by more than one row (junction_board.h GridFromJunctions). The oracle is the model's
// projection of the boards' true corners (ComputeTruth: null behind a post or beyond a ring): the
// corners found must carry the id of the nearest true corner (none behind the post, whose truth
// is null), sub-pixel, and most of those in plain sight must be found.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "detectors/detect_image.h"
#include "io/model_file.h"
#include "synthetic/image_effects.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "tests/render_window.h"
#include "tests/temp_dir.h"

namespace omni::detectors {
namespace {

namespace fs = std::filesystem;

RigParams Prototype() {
  return synthetic::RigAtImageSize(
      io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_prototype.yaml"), 640,
      512);
}

// Corners of target 0 visible via `mirror` (1 or 2) in the truth.
int Visible(const std::vector<TruthCorner>& truth, int mirror) {
  return static_cast<int>(std::count_if(truth.begin(), truth.end(), [&](const TruthCorner& c) {
    return c.target == 0 && c.pixel[mirror - 1].has_value();
  }));
}

struct Found {
  int ring1 = 0, ring2 = 0, wrong = 0;
  double mean_px = 0, max_px = 0;
};

// Renders the scene's one image (windows around its board in each ring, noise sigma 1), detects,
// and matches every corner found to the nearest true corner in its ring.
Found RenderAndDetect(const RigParams& rig, const synthetic::Scene& scene, const std::string& tag) {
  const RigModel model(rig);
  const synthetic::SceneImage& image = scene.images[0];
  const std::vector<TruthCorner> truth = synthetic::ComputeTruth(model, scene, image);
  const std::string dir = testing::UniqueTempDir("omni_chessboard_posts_" + tag);
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::Mat pinhole(rig.image_height, rig.image_width, CV_8UC3, cv::Scalar::all(0));
  std::string error;
  EXPECT_TRUE(testing::RenderTargetWindows(rig, scene, image, truth, dir, &pinhole, &error)) << error;
  cv::Mat raw = synthetic::ApplyDistortion(pinhole, rig);
  synthetic::AddNoise(&raw, 1.0, 7);
  cv::imwrite(dir + "/" + tag + ".png", raw);  // to look at when the test fails
  DetectorContext ctx(rig, scene.targets, /*use_lips=*/false);
  ctx.guided.enabled = false;  // each ring's own detection (guided_detection.h would fill the cut ring)
  const ImageObservations det = DetectImage(raw, &ctx);
  Found f;
  std::vector<double> errors;
  for (const auto& o : det.corners) {
    const TrueCornerMatch match = NearestTrueCorner(truth, o.mirror, o.pixel);
    if (!match.corner || match.corner->target != o.target || match.corner->id != o.id || match.distance_px > 1.0) {
      ++f.wrong;
      ADD_FAILURE() << tag << ": target " << o.target << " id " << o.id << " ring " << MirrorIndex(o.mirror)
                    << ": the nearest truth is " << (match.corner ? match.corner->id : -1) << " at "
                    << match.distance_px << " px";
      continue;
    }
    (o.mirror == Mirror::kOne ? f.ring1 : f.ring2) += 1;
    errors.push_back(match.distance_px);
  }
  for (double e : errors) f.mean_px += e / errors.size();
  f.max_px = errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end());
  std::printf("%s: ring 1 %d of %d, ring 2 %d of %d visible found, mean %.3f px, max %.3f px, %d wrong\n",
              tag.c_str(), f.ring1, Visible(truth, 1), f.ring2, Visible(truth, 2), f.mean_px, f.max_px, f.wrong);
  return f;
}

// One board facing the axis at `azimuth` (rad), `range` mm from it, its centre at height z (C).
synthetic::Scene OneBoard(const TargetSpec& spec, double azimuth, double range, double z) {
  synthetic::Scene scene;
  scene.targets = {spec};
  synthetic::SceneImage image{"board", {}};
  image.placements.push_back(synthetic::PlaceFacingAxis(
      spec, 0, Eigen::Vector3d(range * std::cos(azimuth), range * std::sin(azimuth), z)));
  scene.images.push_back(image);
  return scene;
}

double MidHeight(const RigParams& rig) {
  const IdealModel ideal = rig.Ideal();
  return 0.5 * (ideal.c1 + ideal.d - ideal.c2);
}

// A 3x8 board (90 mm squares) 0.7 m away at azimuth 87 deg, at mid height: the post at 90 deg
// hides its corner column 4 in both rings (ComputeTruth: 21 of 24 visible in each), splitting
// its junctions into two grids of 4 and 3 columns, which neither OpenCV finder reads whole.
TEST(ChessboardPosts, ABoardCrossedByAPostKeepsItsVisibleCorners) {
  const RigParams rig = Prototype();
  ASSERT_TRUE(rig.mount.present);
  const synthetic::Scene scene = OneBoard(ChessboardSpec(3, 8, 90), 87 * M_PI / 180, 700, MidHeight(rig));
  const std::vector<TruthCorner> truth = synthetic::ComputeTruth(RigModel(rig), scene, scene.images[0]);
  ASSERT_EQ(Visible(truth, 1), 21);
  ASSERT_EQ(Visible(truth, 2), 21);
  const Found f = RenderAndDetect(rig, scene, "post");
  EXPECT_EQ(f.wrong, 0);
  EXPECT_GE(f.ring1, 19);  // 21 measured (0 while a board had to be whole but for one row)
  EXPECT_GE(f.ring2, 18);  // 20 measured (0 before)
  EXPECT_LT(f.mean_px, 0.15);
  EXPECT_LT(f.max_px, 0.6);
}

// A 6x5 board (60 mm squares) 0.7 m away at azimuth 30 deg, raised until ring 1's upper edge
// cuts its two top rows (the lowest height, in 10 mm steps, where ComputeTruth shows 20 of its 30
// corners in ring 1; all 30 in ring 2). Ring 1 gives the corners it shows, with the ids ring 2
// gives the same corners.
TEST(ChessboardPosts, ABoardCutByTheRingsEdgeByTwoRowsKeepsItsVisibleCorners) {
  const RigParams rig = Prototype();
  const RigModel model(rig);
  synthetic::Scene scene;
  for (double z = MidHeight(rig); z < MidHeight(rig) + 1000; z += 10) {
    scene = OneBoard(ChessboardSpec(6, 5, 60), 30 * M_PI / 180, 700, z);
    if (Visible(synthetic::ComputeTruth(model, scene, scene.images[0]), 1) <= 20) break;
  }
  const std::vector<TruthCorner> truth = synthetic::ComputeTruth(model, scene, scene.images[0]);
  ASSERT_EQ(Visible(truth, 1), 20);
  ASSERT_EQ(Visible(truth, 2), 30);
  const Found f = RenderAndDetect(rig, scene, "rim");
  EXPECT_EQ(f.wrong, 0);
  EXPECT_GE(f.ring1, 18);  // 20 measured (0 while a board had to be whole but for one row)
  EXPECT_GE(f.ring2, 28);
  EXPECT_LT(f.mean_px, 0.15);
  EXPECT_LT(f.max_px, 0.6);
}

}  // namespace
}  // namespace omni::detectors
