// The grid check (grid_check.h GridFitsBoard) where the views come from a start model a few
// pixels off the true one (a single mirror's start from its rim alone): a board's exact corners
// (the true model's projection) bend away from a homography in the start model's views; the
// cubic correction takes that smooth bend, never a mis-ordered pair of corners.
#include <algorithm>
#include <cstdio>
#include <memory>

#include <gtest/gtest.h>

#include "detectors/chessboard/grid_check.h"
#include "model/model_derived.h"
#include "tests/detectors/warped_board.h"

namespace omni::detectors {
namespace {

class GridCheckTest : public ::testing::Test {
 protected:
  void SetUp() override {
    spec_.type = TargetType::kChessboard;
    spec_.rows = 6;
    spec_.cols = 8;
    spec_.square_mm = 30;
    const RigParams truth = testing::Parabolic();
    // The start: the mirror aligned with the lens and its conic and magnification a little off
    // (what a rim-only start gets wrong).
    RigParams start = truth;
    start.mirror1_pose = {0, 0, 0, 0, 0};
    start.mirror1_shape[1] = -0.85;  // K
    start.camera[0] *= 1.04;          // fx, fy
    start.camera[1] *= 1.04;
    start_ = std::make_unique<RigModel>(start);
    const RigModel truth_model(truth);
    const Eigen::Vector3d focus = ComputeModelDerived(truth).focus1_in_cam;
    const double azimuth = 0.3, elevation = -0.3, range = 300;
    const Eigen::Vector3d centre =
        focus + range * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                        std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    const synthetic::Placement place = synthetic::PlaceFacingAxis(spec_, 0, centre);
    views_ = MakeRingViews(*start_);
    // The view the board is most central in.
    double best = 1e9;
    for (size_t v = 0; v < views_.size(); ++v) {
      BoardDetection b;
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      bool all = true;
      for (int id = 0; id < CornerCount(spec_); ++id) {
        const auto raw = truth_model.Project(
            place.cam_from_target_rotation * CornerInTarget(spec_, id) + place.cam_from_target_translation,
            Mirror::kOne);
        const auto in_view = raw ? views_[v].RawToView(*start_, *raw) : std::nullopt;
        if (!in_view || in_view->x() < 0 || in_view->y() < 0 || in_view->x() > views_[v].width - 1 ||
            in_view->y() > views_[v].height - 1) {
          all = false;
          break;
        }
        b.ids.push_back(id);
        b.raw_pixels.push_back(*raw);
        b.view_pixels.push_back(*in_view);
        mean += *in_view / CornerCount(spec_);
      }
      const double off = (mean - Eigen::Vector2d(views_[v].cx, views_[v].cy)).norm();
      if (all && off < best) {
        best = off;
        view_ = v;
        board_ = b;
      }
    }
  }

  TargetSpec spec_;
  std::unique_ptr<RigModel> start_;
  std::vector<RingView> views_;
  size_t view_ = 0;
  BoardDetection board_;
};

TEST_F(GridCheckTest, TheCubicTakesTheStartModelsBend) {
  ASSERT_EQ(board_.ids.size(), 48u);
  ChessboardOptions plain;
  plain.smooth_grid_correction = false;
  BoardDetection b = board_;
  const bool plain_ok = GridFitsBoard(views_[view_], *start_, spec_.cols, plain, &b);
  const size_t plain_kept = plain_ok ? b.ids.size() : 0;
  // The start model's bend is beyond the plain homography's 0.5 px: corners lost or the board.
  EXPECT_LT(plain_kept, 48u);
  ChessboardOptions smooth;
  smooth.smooth_grid_correction = true;
  b = board_;
  ASSERT_TRUE(GridFitsBoard(views_[view_], *start_, spec_.cols, smooth, &b));
  EXPECT_EQ(b.ids.size(), 48u);
  std::printf("plain homography: %zu of 48 kept; with the cubic: %zu\n", plain_kept, b.ids.size());
}

// Two neighbouring corners swapped (the finders' mis-ordered ids): a third of a square or more
// off their grid points, which no smooth bend explains. Neither is kept.
TEST_F(GridCheckTest, AMisorderedPairIsNotBentIn) {
  ASSERT_EQ(board_.ids.size(), 48u);
  ChessboardOptions smooth;
  smooth.smooth_grid_correction = true;
  for (const auto& [a, b] : {std::pair{19, 20}, std::pair{3, 11}, std::pair{46, 47}}) {
    BoardDetection swapped = board_;
    std::swap(swapped.raw_pixels[a], swapped.raw_pixels[b]);
    if (!GridFitsBoard(views_[view_], *start_, spec_.cols, smooth, &swapped)) continue;  // refused whole
    for (int id : swapped.ids) {
      EXPECT_NE(id, a);
      EXPECT_NE(id, b);
    }
    EXPECT_EQ(swapped.ids.size(), 46u);
  }
}

}  // namespace
}  // namespace omni::detectors
