// The corner-window policy (corner_window.h) at the image sizes of the rendered sessions, against
// the windows the detectors used before it (written out: 0.55 squares clamped to 2..8 px, 0.15
// tags, max(1.5, 0.12 tags)), and the detector options' checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "detectors/apriltag/apriltag_detector.h"
#include "detectors/chessboard/chessboard_detector.h"
#include "detectors/common/corner_window.h"
#include "detectors/common/saddle_points.h"
#include "detectors/common/views.h"
#include "detectors/guided_detection.h"
#include "detectors/lip_guide.h"
#include "detectors/lips/post_finder.h"
#include "io/model_file.h"

namespace omni::detectors {
namespace {

RigParams BigRigAt(int width, int height) {
  RigParams rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_ideal.yaml");
  const double scale = static_cast<double>(width) / rig.image_width;
  for (int k = 0; k < 4; ++k) rig.camera[k] *= scale;
  rig.image_width = width;
  rig.image_height = height;
  return rig;
}

int FixedPixelWindow(double side) {
  return side < 3.0 ? 1 : std::clamp(static_cast<int>(std::lround(0.55 * side)), 2, 8);
}

TEST(CornerWindow, ChessboardWindowsAreTheFixedOnesAt1280x960And960x720) {
  for (const auto& [w, h] : {std::pair{1280, 960}, {960, 720}}) {
    const double px_per_deg = CameraPixelsPerDegree(BigRigAt(w, h));
    for (double side = 0.5; side < 60; side += 0.137) {
      EXPECT_EQ(ChessboardHalfWindow(side, px_per_deg), FixedPixelWindow(side)) << w << " " << side;
    }
  }
}

TEST(CornerWindow, TheChessboardCapGrowsWithTheViewAt5MP) {
  const RigParams rig = BigRigAt(2592, 1944);
  const double px_per_deg = CameraPixelsPerDegree(rig);
  EXPECT_NEAR(px_per_deg, 0.5 * (rig.camera[kFx] + rig.camera[kFy]) * M_PI / 180, 1e-12);
  EXPECT_EQ(ChessboardHalfWindow(10, px_per_deg), 6);    // 0.55 squares below the cap
  EXPECT_EQ(ChessboardHalfWindow(20, px_per_deg), 11);
  EXPECT_EQ(ChessboardHalfWindow(100, px_per_deg), 16);  // 0.316 degrees at 51.3 px/deg
  EXPECT_EQ(ChessboardHalfWindow(2.9, px_per_deg), 1);
}

TEST(CornerWindow, TagWindowsAreFractionsOfTheTagSide) {
  for (double side = 1; side < 200; side += 0.73) {
    EXPECT_EQ(TagCornerHalfWindow(side), static_cast<int>(std::lround(0.15 * side)));
    EXPECT_EQ(XJunctionProbe(side), std::max(1.5, 0.12 * side));
  }
}

TEST(DetectorOptions, DefaultsPassTheirChecksAndBadValuesAreNamed) {
  EXPECT_EQ(ViewOptions().Check(), "");
  EXPECT_EQ(ChessboardOptions().Check(), "");
  EXPECT_EQ(TagDetectorOptions().Check(), "");
  EXPECT_EQ(GuidedOptions().Check(), "");
  ViewOptions views;
  views.horizontal_fov_deg = 190;
  EXPECT_EQ(views.Check(), "horizontal_fov_deg: expected an angle in (0, 180) degrees, got 190");
  EXPECT_THROW(MakeRingViews(RigModel(BigRigAt(1280, 960)), views), std::invalid_argument);
  ChessboardOptions chessboard;
  chessboard.min_grid_inlier_fraction = 1.5;
  EXPECT_EQ(chessboard.Check(), "min_grid_inlier_fraction: expected a fraction in [0, 1], got 1.5");
  TagDetectorOptions tags;
  tags.kalibr.upsample = 0;
  EXPECT_EQ(tags.Check(), "kalibr.upsample: expected an enlargement of at least 1, got 0");
  tags = TagDetectorOptions();
  tags.kalibr_region_pad_deg = -1;
  EXPECT_EQ(tags.Check(), "kalibr_region_pad_deg: expected an angle >= 0 degrees, got -1");
  tags = TagDetectorOptions();
  tags.kalibr_saddles.sigma = 0;
  EXPECT_EQ(tags.Check(), "kalibr_saddles.sigma: expected a smoothing > 0 view px, got 0");
  GuidedOptions guided;
  guided.max_prediction_error_deg = 0;
  EXPECT_EQ(guided.Check(), "max_prediction_error_deg: expected an angle > 0 degrees, got 0");
  guided = GuidedOptions();
  guided.grid_check.min_corners = 3;
  EXPECT_EQ(guided.Check(), "grid_check.min_corners: expected at least 4 corners (a homography), got 3");
  EXPECT_EQ(SaddleOptions().Check(), "");
  EXPECT_EQ(LipGuideOptions().Check(), "");
  LipGuideOptions guide;
  guide.f_scan = {0.96, 3};
  EXPECT_EQ(guide.Check(), "f_scan: expected scales of f in (0.5, 2), got 3");
  EXPECT_EQ(PostFinderOptions().Check(), "");
  PostFinderOptions posts;
  posts.elevations = 0;
  EXPECT_EQ(posts.Check(), "elevations: expected at least 8 samples, got 0");
}

}  // namespace
}  // namespace omni::detectors
