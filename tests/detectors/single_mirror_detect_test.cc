// Detection in a single-mirror camera's one ring (issue 47 item 5): views and ring layout from the
// model's own tracing, and chessboards found in exact warps of a board through the model (each
// raw pixel back-projected by RigModel::Unproject onto the board's plane, 3 x 3 samples per
// pixel: an oracle independent of the views' forward projection), scored against the
// projected corners. Parabolic + telecentric (Mei's kind of camera) and hyperbolic + perspective,
// both misaligned.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "detectors/detect_image.h"
#include "tests/detectors/warped_board.h"
#include "model/central_mirror.h"
#include "model/model_derived.h"
#include "synthetic/scene.h"

namespace omni::detectors {
namespace {

using testing::Hyperbolic;
using testing::Parabolic;
using testing::WarpBoard;

struct Score {
  int truth = 0, found = 0, wrong = 0;
  double sum = 0, worst = 0;
};

Score DetectBoards(const RigParams& rig, const std::vector<std::pair<double, double>>& az_el,
                   double range) {
  const RigModel model(rig);
  TargetSpec spec;
  spec.type = TargetType::kChessboard;
  spec.rows = 6;
  spec.cols = 8;
  spec.square_mm = 30;
  const Eigen::Vector3d focus = ComputeModelDerived(rig).focus1_in_cam;
  Score score;
  DetectorContext ctx(rig, {spec}, false);
  for (const auto& [azimuth, elevation] : az_el) {
    const Eigen::Vector3d centre =
        focus + range * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                        std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    const synthetic::Placement place = synthetic::PlaceFacingAxis(spec, 0, centre);
    const cv::Mat raw = WarpBoard(model, spec, place);
    const ImageObservations det = DetectImage(raw, &ctx);
    for (int id = 0; id < CornerCount(spec); ++id) {
      const auto truth = model.Project(
          place.cam_from_target_rotation * CornerInTarget(spec, id) + place.cam_from_target_translation,
          Mirror::kOne);
      if (!truth) continue;
      ++score.truth;
      for (const CornerObservation& c : det.corners) {
        if (c.id != id) continue;
        const double e = (c.pixel - *truth).norm();
        if (e > 1.0) continue;
        ++score.found;
        score.sum += e;
        score.worst = std::max(score.worst, e);
      }
    }
    for (const CornerObservation& c : det.corners) {
      EXPECT_EQ(c.mirror, Mirror::kOne);
      const auto truth = model.Project(
          place.cam_from_target_rotation * CornerInTarget(spec, c.id) + place.cam_from_target_translation,
          Mirror::kOne);
      if (!truth || (c.pixel - *truth).norm() > 1.0) ++score.wrong;
    }
  }
  return score;
}

// The views cover the one ring: 8 views of mirror 1, each showing the ring, their maps the
// model's projection; the layout's ring is where the model traces rays through the mirror.
TEST(SingleMirrorViewsTest, OneRingOfViewsAndLayout) {
  for (const RigParams& rig : {Parabolic(), Hyperbolic()}) {
    const RigModel model(rig);
    const std::vector<RingView> views = MakeRingViews(model);
    ASSERT_EQ(views.size(), 8u);
    std::mt19937 rng(7);
    for (const RingView& view : views) {
      EXPECT_EQ(view.mirror, Mirror::kOne);
      std::uniform_real_distribution<double> x(0, view.width - 1), y(0, view.height - 1);
      int valid = 0;
      for (int i = 0; i < 200; ++i) {
        const Eigen::Vector2d p(x(rng), y(rng));
        const auto exact = view.ViewToRawExact(model, p);
        const auto interp = view.ViewToRaw(p);
        if (!exact || !interp) continue;
        ++valid;
        EXPECT_LT((*exact - *interp).norm(), 0.05);
        const auto back = view.RawToView(model, *exact);
        ASSERT_TRUE(back.has_value());
        EXPECT_LT((*back - p).norm(), 1e-3);
      }
      EXPECT_GT(valid, 100);
    }
    const RingLayout layout = ComputeRingLayout(model);
    std::uniform_real_distribution<double> u(0, layout.width - 1), v(0, layout.height - 1);
    int checked = 0;
    for (int i = 0; i < 5000; ++i) {
      const Eigen::Vector2d pixel(u(rng), v(rng));
      const bool in_ring = layout.LabelAt(pixel) == RingLabel::kMirror1;
      if (std::abs(layout.DepthInRing(pixel, Mirror::kOne)) < 1.5) continue;
      EXPECT_NE(layout.LabelAt(pixel), RingLabel::kMirror2);
      EXPECT_EQ(in_ring, model.Unproject(pixel).has_value()) << pixel.transpose();
      ++checked;
    }
    EXPECT_GT(checked, 3000);
  }
}

// Boards near the rim, mid-ring and towards the centre, at several azimuths: every corner found,
// none with a wrong id, sub-0.1 px on average.
TEST(SingleMirrorChessboardTest, BoardsInTheOneRing) {
  const std::vector<std::pair<double, double>> az_el = {
      {0.3, -0.15}, {1.9, -0.45}, {3.4, -0.75}, {4.6, -0.3}};
  for (const RigParams& rig : {Parabolic(), Hyperbolic()}) {
    const Score s = DetectBoards(rig, az_el, 450);
    SCOPED_TRACE(LensKindName(rig.lens));
    EXPECT_GT(s.truth, 150);
    EXPECT_GE(s.found, 0.95 * s.truth);
    EXPECT_EQ(s.wrong, 0);
    EXPECT_LT(s.sum / std::max(1, s.found), 0.1);
    std::printf("%s: %d of %d corners, %d wrong, mean %.3f px, worst %.3f px\n", LensKindName(rig.lens),
                s.found, s.truth, s.wrong, s.sum / std::max(1, s.found), s.worst);
  }
}

}  // namespace
}  // namespace omni::detectors
