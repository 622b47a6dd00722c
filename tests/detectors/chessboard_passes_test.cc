// DetectImage's two chessboard passes on a single mirror (detect_image.cc ChessboardsBrightThenDim):
// a board in shade, whose junctions are under the absolute saddle threshold, is found by the
// second pass (relative contrast) and only for the target the first pass lacked. Boards are
// warped into the raw image through the model (warped_board.h); the oracle is the model's
// projection of each corner.
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "detectors/detect_image.h"
#include "model/model_derived.h"
#include "tests/detectors/warped_board.h"

namespace omni::detectors {
namespace {

TargetSpec Board(int rows, int cols, double square_mm) {
  TargetSpec spec;
  spec.type = TargetType::kChessboard;
  spec.rows = rows;
  spec.cols = cols;
  spec.square_mm = square_mm;
  return spec;
}

synthetic::Placement Place(const RigParams& rig, const TargetSpec& spec, int target, double azimuth,
                           double elevation, double range) {
  const Eigen::Vector3d focus = ComputeModelDerived(rig).focus1_in_cam;
  const Eigen::Vector3d centre =
      focus + range * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                      std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
  return synthetic::PlaceFacingAxis(spec, target, centre);
}

struct TargetScore {
  int found = 0, wrong = 0;
  double worst = 0;
};

// Per target: corners within 0.5 px of their own id's projection (found) and the others (wrong).
std::map<int, TargetScore> Score(const RigModel& model, const std::vector<TargetSpec>& specs,
                                 const std::vector<synthetic::Placement>& places,
                                 const std::vector<CornerObservation>& corners) {
  std::map<int, TargetScore> out;
  for (const CornerObservation& c : corners) {
    const synthetic::Placement& p = places[c.target];
    const auto truth = model.Project(
        p.cam_from_target_rotation * CornerInTarget(specs[c.target], c.id) + p.cam_from_target_translation,
        Mirror::kOne);
    TargetScore& s = out[c.target];
    if (truth && (c.pixel - *truth).norm() < 0.5) {
      ++s.found;
      s.worst = std::max(s.worst, (c.pixel - *truth).norm());
    } else {
      ++s.wrong;
    }
  }
  return out;
}

// A bright 6x8 board (squares 30 / 220) and a 5x7 board in shade (60 / 110: 50 levels, under the
// absolute threshold of 125) in one photo of a paraboloid behind a telecentric lens.
class DimBoardTest : public ::testing::Test {
 protected:
  void SetUp() override {
    specs_ = {Board(6, 8, 30), Board(5, 7, 30)};
    places_ = {Place(rig_, specs_[0], 0, 0.3, -0.3, 450), Place(rig_, specs_[1], 1, 3.4, -0.45, 450)};
    image_ = testing::WarpBoard(model_, specs_[0], places_[0]);
    testing::WarpBoard(model_, specs_[1], places_[1], 60, 110, image_);
  }
  RigParams rig_ = testing::Parabolic();
  RigModel model_{rig_};
  std::vector<TargetSpec> specs_;
  std::vector<synthetic::Placement> places_;
  cv::Mat image_;
};

TEST_F(DimBoardTest, TheSecondPassFindsTheBoardInShade) {
  DetectorContext ctx(rig_, specs_, false);
  ASSERT_GT(ctx.chessboard.saddle_relative_contrast, 0);  // on for single rigs
  const std::map<int, TargetScore> s = Score(model_, specs_, places_, DetectImage(image_, &ctx).corners);
  ASSERT_EQ(s.count(0), 1u);
  ASSERT_EQ(s.count(1), 1u);
  // Every corner once (the first pass's board is not found again by the second), none wrong.
  EXPECT_EQ(s.at(0).found, 48);
  EXPECT_EQ(s.at(1).found, 35);
  EXPECT_EQ(s.at(0).wrong + s.at(1).wrong, 0);
  EXPECT_LT(s.at(1).worst, 0.2);
  std::printf("bright %d, dim %d corners (worst %.3f / %.3f px)\n", s.at(0).found, s.at(1).found,
              s.at(0).worst, s.at(1).worst);
}

TEST_F(DimBoardTest, WithoutTheSecondPassTheBoardInShadeIsLost) {
  DetectorContext ctx(rig_, specs_, false);
  ctx.chessboard.saddle_relative_contrast = 0;
  ctx.chessboard.search_photo = false;  // the photo's own finder (raw_board.h) would find it
  const std::map<int, TargetScore> s = Score(model_, specs_, places_, DetectImage(image_, &ctx).corners);
  EXPECT_EQ(s.count(0) ? s.at(0).found : 0, 48);
  EXPECT_EQ(s.count(1), 0u);  // the test's board really is below the absolute threshold
}

}  // namespace
}  // namespace omni::detectors
