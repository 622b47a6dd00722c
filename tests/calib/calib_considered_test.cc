// Considered parameters (calib/calibrate.h): a detector offset common to one ring's corners, the
// same in every image. Its column of the covariance's sensitivity (d value / d offset, from the
// Schur complement) against the finite difference of two solves on the same noisy detections,
// one with the offset added to the inner ring's corners: the linear prediction must match.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "calib/calibrate.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

TEST(CalibConsidered, CornerOffsetSensitivityMatchesSolvingAgain) {
  testing::SyntheticSession session;
  const RigParams truth = testing::SmallCleanSessionWithoutTangential(&session);
  const Observations detections = testing::NoisyDetections(session, 0.01, 7);
  // Observed = true + offset in the inner ring, on 0.01 px noise: the reflex tilt moves by ~2 of
  // its noise sigmas, the others by less, in the linear range.
  const Eigen::Vector2d offset(0.2, -0.3);
  Observations shifted = detections;
  for (auto& image : shifted.images) {
    for (auto& c : image.corners) {
      if (c.mirror == Mirror::kTwo) c.pixel += offset;
    }
  }
  CalibrationOptions options;
  options.solver.threads = 2;
  const CalibrationResult a = Calibrate(truth, session.targets, detections, options);
  const CalibrationResult b = Calibrate(truth, session.targets, shifted, options);
  ASSERT_EQ(a.corner_offsets_considered, 4);
  ASSERT_EQ(a.names, b.names);
  const int n_columns = static_cast<int>(a.considered_column_sigma.size());
  ASSERT_EQ(a.considered_sensitivity.cols(), n_columns);
  const int ring2_u = n_columns - 2;  // ring 1 u, v, ring 2 u, v last
  EXPECT_DOUBLE_EQ(a.considered_column_sigma(ring2_u), options.corner_offset_sigma_px);
  int moved = 0;
  for (size_t i = 0; i < a.names.size(); ++i) {
    const double predicted = a.considered_sensitivity(i, ring2_u) * offset.x() +
                             a.considered_sensitivity(i, ring2_u + 1) * offset.y();
    const double solved = b.values(i) - a.values(i);
    std::printf("%-12s solved %+.3e predicted %+.3e (noise sigma %.3e)\n", a.names[i].c_str(),
                solved, predicted, a.noise_sigma(i));
    // Within 10% of the move and 5% of the noise sigma (the two solves stop at their own
    // tolerances).
    EXPECT_NEAR(solved, predicted, 0.1 * std::abs(predicted) + 0.05 * a.noise_sigma(i)) << a.names[i];
    moved += std::abs(predicted) > a.noise_sigma(i);
  }
  // The offset is felt: the reflex tilt at least moves by more than its noise.
  EXPECT_GE(moved, 1);
  // And its sigma carries it: total^2 = noise^2 + the considered columns' shares.
  for (size_t i = 0; i < a.names.size(); ++i) {
    double share = 0;
    for (int c = ring2_u; c < n_columns; ++c) {
      share += std::pow(a.considered_sensitivity(i, c) * a.considered_column_sigma(c), 2);
    }
    EXPECT_GE(a.sigma(i) * a.sigma(i) + 1e-18, a.noise_sigma(i) * a.noise_sigma(i) + share * 0.999)
        << a.names[i];
  }
}

}  // namespace
}  // namespace omni::calib
