// synthetic/render_bias.h's statistics on hand-made corners whose offsets are known.
#include "synthetic/render_bias.h"

#include <cmath>

#include <gtest/gtest.h>

namespace omni::synthetic {
namespace {

BiasSetup TwoCorners() {
  BiasSetup s;
  s.rig.camera = {1000, 1000, 100, 100, 0};  // principal point (100, 100)
  s.corners.resize(3);
  s.corners[0].ring = 1;
  s.corners[0].truth = Eigen::Vector2d(200, 100);  // radial direction +u
  s.corners[1].ring = 1;
  s.corners[1].truth = Eigen::Vector2d(100, 300);  // radial direction +v
  s.corners[2].ring = 2;
  s.corners[2].truth = Eigen::Vector2d(0, 100);    // radial direction -u
  return s;
}

// Radial away from the principal point, tangential counter-clockwise in pixels (r x e); a
// corner more than 0.5 px off is lost, not a bias; differences only where both are measured.
TEST(RenderBias, OffsetsPerRing) {
  const BiasSetup s = TwoCorners();
  const std::vector<Eigen::Vector2d> errors =
      ErrorsOf(s, {Eigen::Vector2d(200.1, 100.02), Eigen::Vector2d(100, 300.3),
                   Eigen::Vector2d(0.6, 100)});
  EXPECT_TRUE(std::isnan(errors[2].x()));
  const std::map<int, RingBias> bias = BiasByRing(s, errors);
  ASSERT_EQ(bias.size(), 1u);
  const RingBias& ring1 = bias.at(1);
  EXPECT_EQ(ring1.n, 2);
  EXPECT_NEAR(ring1.radial, (0.1 + 0.3) / 2, 1e-9);
  EXPECT_NEAR(ring1.tangential, 0.02 / 2, 1e-9);
  EXPECT_NEAR(ring1.mean.x(), 0.05, 1e-9);
  EXPECT_NEAR(ring1.rms, std::sqrt((0.01 + 0.0004 + 0.09) / 2), 1e-9);
  EXPECT_EQ(BiasLine("x", bias, -1).rfind("x           ring 1: n   2 radial +0.2000", 0), 0u)
      << BiasLine("x", bias, -1);
  const std::vector<Eigen::Vector2d> d =
      Difference(errors, {Eigen::Vector2d(0.05, 0), Eigen::Vector2d(NAN, NAN),
                          Eigen::Vector2d(0, 0)});
  EXPECT_NEAR(d[0].x(), 0.05, 1e-12);
  EXPECT_TRUE(std::isnan(d[1].x()));
  EXPECT_TRUE(std::isnan(d[2].x()));
}

TEST(RenderBias, DetectorHalfWindow) {
  EXPECT_EQ(DetectorHalfWindow(1, 0), 1);
  EXPECT_EQ(DetectorHalfWindow(10, 0), 4);
  EXPECT_EQ(DetectorHalfWindow(40, 0), 6);
  EXPECT_EQ(DetectorHalfWindow(40, 3), 3);
}

}  // namespace
}  // namespace omni::synthetic
