// A single mirror's chessboard that no view holds, found in the photo itself (raw_board.h):
// exact warps of a board through a misaligned model (warped_board.h: each raw pixel
// back-projected onto the board's plane, an oracle independent of the views and the finder),
// the corners against the model's projection of the board's corners, ids exact (the views'
// rule); and the X-junction test against an L-corner of a board's border.
#include "detectors/chessboard/raw_board.h"

#include <cmath>

#include <gtest/gtest.h>

#include "detectors/detect_image.h"
#include "model/model_derived.h"
#include "tests/detectors/warped_board.h"

namespace omni::detectors {
namespace {

using testing::Hyperbolic;
using testing::WarpBoard;

// A 6x8 board of 30 mm squares (270 mm wide) 150 mm from the mirror's focus: it spans about
// 85 degrees of azimuth, more than the 45 degrees by which the 8 views of 90 overlap.
struct CloseBoard {
  RigParams rig = Hyperbolic();
  RigModel model{rig};
  TargetSpec spec;
  synthetic::Placement place;
  cv::Mat raw;
  CloseBoard() {
    spec.type = TargetType::kChessboard;
    spec.rows = 6;
    spec.cols = 8;
    spec.square_mm = 30;
    const Eigen::Vector3d focus = ComputeModelDerived(rig).focus1_in_cam;
    const double azimuth = 0.3, elevation = -0.65, range = 170;
    place = synthetic::PlaceFacingAxis(
        spec, 0,
        focus + range * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                        std::cos(elevation) * std::sin(azimuth), std::sin(elevation)));
    raw = WarpBoard(model, spec, place);
  }
  std::optional<Eigen::Vector2d> Truth(int id) const {
    return model.Project(place.cam_from_target_rotation * CornerInTarget(spec, id) +
                             place.cam_from_target_translation,
                         Mirror::kOne);
  }
};

TEST(RawBoard, ABoardNoViewHoldsIsFoundInThePhotoWithTheViewsIds) {
  const CloseBoard b;
  const auto board = FindBoardInPhoto(b.raw, b.raw, b.model, b.spec, 0, 0, ChessboardOptions{});
  ASSERT_TRUE(board);
  EXPECT_GE(board->ids.size(), 44u);  // of 48
  double worst = 0;
  for (size_t i = 0; i < board->ids.size(); ++i) {
    const auto truth = b.Truth(board->ids[i]);
    ASSERT_TRUE(truth);
    worst = std::max(worst, (board->raw_pixels[i] - *truth).norm());
  }
  EXPECT_LT(worst, 0.25);  // and so every id right: a neighbour is a square (> 10 px) away

  // Through DetectImage: the views find no board here, the photo's finder does.
  DetectorContext ctx(b.rig, {b.spec}, false);
  const ImageObservations det = DetectImage(b.raw, &ctx);
  ASSERT_GE(det.corners.size(), 44u);
  for (const CornerObservation& c : det.corners) {
    const auto truth = b.Truth(c.id);
    ASSERT_TRUE(truth);
    EXPECT_LT((c.pixel - *truth).norm(), 0.25) << "id " << c.id;
  }
}

TEST(RawBoard, NoBoardNoCorners) {
  const CloseBoard b;
  const cv::Mat plain(b.raw.size(), CV_8U, cv::Scalar(90));
  EXPECT_FALSE(FindBoardInPhoto(plain, plain, b.model, b.spec, 0, 0, ChessboardOptions{}));
}

// An X-junction's opposite quadrants alike; an L-corner of the border (one dark quadrant of
// four, the finder's outer row on a public hyperbolic-mirror photo) is refused, as is a plain
// edge (two dark quadrants side by side).
TEST(RawBoard, XJunctionsNotLCornersOrEdges) {
  EXPECT_TRUE(IsXJunction(30, 220, 220, 30));
  EXPECT_TRUE(IsXJunction(200, 60, 40, 210));
  EXPECT_FALSE(IsXJunction(30, 220, 220, 220));  // L-corner
  EXPECT_FALSE(IsXJunction(30, 30, 220, 220));   // edge
  EXPECT_FALSE(IsXJunction(120, 125, 118, 122)); // flat
}

}  // namespace
}  // namespace omni::detectors
