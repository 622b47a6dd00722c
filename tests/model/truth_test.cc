// NearestTrueCorner, the one matcher of detections to a synthetic session's truth: hand-made
// corners whose answer is known (nearest, rings required, the larger ring distance, max_px
// strict, the first of equals, the admit filter).
#include "model/truth.h"

#include <gtest/gtest.h>

namespace omni {
namespace {

TruthCorner Corner(int target, int id, std::optional<Eigen::Vector2d> px1,
                   std::optional<Eigen::Vector2d> px2) {
  TruthCorner c;
  c.target = target;
  c.id = id;
  c.pixel[0] = px1;
  c.pixel[1] = px2;
  return c;
}

TEST(NearestTrueCorner, OneRingTakesTheNearestSeenInThatRing) {
  const std::vector<TruthCorner> corners = {
      Corner(0, 1, Eigen::Vector2d(10, 10), std::nullopt),
      Corner(0, 2, std::nullopt, Eigen::Vector2d(10.5, 10)),  // ring 2 only
      Corner(1, 1, Eigen::Vector2d(12, 10), Eigen::Vector2d(50, 50))};
  const TrueCornerMatch m1 = NearestTrueCorner(corners, Mirror::kOne, Eigen::Vector2d(10.4, 10));
  ASSERT_EQ(m1.corner, &corners[0]);
  EXPECT_NEAR(m1.distance_px, 0.4, 1e-12);
  const TrueCornerMatch m2 = NearestTrueCorner(corners, Mirror::kTwo, Eigen::Vector2d(10.4, 10));
  ASSERT_EQ(m2.corner, &corners[1]);
  EXPECT_NEAR(m2.distance_px, 0.1, 1e-12);
  // Filtered to target 1: the far one.
  const TrueCornerMatch m3 = NearestTrueCorner(corners, Mirror::kOne, Eigen::Vector2d(10.4, 10),
                                               HUGE_VAL,
                                               [](const TruthCorner& c) { return c.target == 1; });
  ASSERT_EQ(m3.corner, &corners[2]);
  EXPECT_NEAR(m3.distance_px, 1.6, 1e-12);
  // Beyond max_px (strict): none.
  EXPECT_EQ(NearestTrueCorner(corners, Mirror::kOne, Eigen::Vector2d(10.4, 10), 0.4).corner,
            nullptr);
  EXPECT_EQ(NearestTrueCorner({}, Mirror::kOne, Eigen::Vector2d(0, 0)).corner, nullptr);
}

TEST(NearestTrueCorner, BothRingsJudgeByTheLargerDistanceAndNeedBoth) {
  const std::vector<TruthCorner> corners = {
      Corner(0, 7, Eigen::Vector2d(0, 0), std::nullopt),             // not seen in ring 2
      Corner(0, 7, Eigen::Vector2d(0, 0.1), Eigen::Vector2d(100, 2)),  // ring 2 off by 2
      Corner(0, 8, Eigen::Vector2d(0, 1), Eigen::Vector2d(100, 1)),    // 1 px in both
      Corner(0, 9, Eigen::Vector2d(0, 1), Eigen::Vector2d(100, 1))};   // its equal, later
  const std::optional<Eigen::Vector2d> pixels[2] = {Eigen::Vector2d(0, 0),
                                                    Eigen::Vector2d(100, 0)};
  const TrueCornerMatch m = NearestTrueCorner(corners, pixels);
  ASSERT_EQ(m.corner, &corners[2]);  // max(1, 1) beats max(0.1, 2); the first of equals
  EXPECT_NEAR(m.distance_px, 1.0, 1e-12);
  const TrueCornerMatch by_id = NearestTrueCorner(
      corners, pixels, 3.0, [](const TruthCorner& c) { return c.id == 7; });
  ASSERT_EQ(by_id.corner, &corners[1]);
  EXPECT_NEAR(by_id.distance_px, 2.0, 1e-12);
  EXPECT_EQ(NearestTrueCorner(corners, pixels, 2.0,
                              [](const TruthCorner& c) { return c.id == 7; }).corner,
            nullptr);
}

}  // namespace
}  // namespace omni
