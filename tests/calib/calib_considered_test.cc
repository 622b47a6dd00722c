// Considered parameters (calib/calibrate.h): detector biases the same in every image, a common
// offset of one ring's corners and a lip edge's move as a whole. Their columns of the covariance's
// sensitivity (d value / d bias, from the Schur complement) against the finite difference of two
// solves on the same noisy detections, one with the bias added: the linear prediction must match.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "calib/calibrate.h"
#include "model/lip.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

int Column(const CalibrationResult& r, const std::string& name) {
  for (size_t c = 0; c < r.uncertainty.considered_column_names.size(); ++c) {
    if (r.uncertainty.considered_column_names[c] == name) return static_cast<int>(c);
  }
  ADD_FAILURE() << "no considered column " << name;
  return -1;
}

// Solves `detections` and `moved` (the same with a bias added) from the truth and expects the
// parameters to move as columns c0, c0 + 1 of the sensitivity predict for `offset`, per parameter
// within 10% of the move and 5% of the noise sigma; at least one moves by more than its noise.
void ExpectMoveAsPredicted(const RigParams& truth, const std::vector<TargetSpec>& targets,
                           const Observations& detections, const Observations& moved,
                           const std::string& column, const Eigen::Vector2d& offset) {
  CalibrationOptions options;
  options.solver.threads = 2;
  // Exact quadrics by construction, and this test's subject is not the mirrors' profile: freed,
  // its valley with tz and fx makes a re-solve differ from the linear prediction (and the
  // coverage decision may differ between the two solves).
  options.profile = "off";
  const CalibrationResult a = Calibrate(truth, targets, detections, options);
  const CalibrationResult b = Calibrate(truth, targets, moved, options);
  ASSERT_EQ(a.estimate.names, b.estimate.names);
  ASSERT_EQ(a.uncertainty.considered_column_names.size(),
            static_cast<size_t>(a.uncertainty.considered_column_sigma.size()));
  const int c0 = Column(a, column + " u");
  ASSERT_EQ(Column(a, column + " v"), c0 + 1);
  int moved_beyond_noise = 0;
  for (size_t i = 0; i < a.estimate.names.size(); ++i) {
    const double predicted = a.uncertainty.considered_sensitivity(i, c0) * offset.x() +
                             a.uncertainty.considered_sensitivity(i, c0 + 1) * offset.y();
    const double solved = b.estimate.values(i) - a.estimate.values(i);
    std::printf("%s: %-12s solved %+.3e predicted %+.3e (noise sigma %.3e)\n", column.c_str(),
                a.estimate.names[i].c_str(), solved, predicted, a.uncertainty.noise_sigma(i));
    EXPECT_NEAR(solved, predicted, 0.1 * std::abs(predicted) + 0.05 * a.uncertainty.noise_sigma(i))
        << column << " " << a.estimate.names[i];
    moved_beyond_noise += std::abs(predicted) > a.uncertainty.noise_sigma(i);
  }
  EXPECT_GE(moved_beyond_noise, 1) << column;
}

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
  ExpectMoveAsPredicted(truth, session.targets, detections, shifted, "corners ring 2", offset);

  // Each sigma carries the considered columns: total^2 = noise^2 + their shares.
  CalibrationOptions options;
  options.solver.threads = 2;
  // Exact quadrics by construction, and this test's subject is not the mirrors' profile: freed,
  // its valley with tz and fx makes a re-solve differ from the linear prediction (and the
  // coverage decision may differ between the two solves).
  options.profile = "off";
  const CalibrationResult a = Calibrate(truth, session.targets, detections, options);
  EXPECT_EQ(a.uncertainty.corner_offsets_considered, 4);
  EXPECT_DOUBLE_EQ(a.uncertainty.considered_column_sigma(Column(a, "corners ring 2 u")),
                   options.corner_offset_sigma_px);
  for (size_t i = 0; i < a.estimate.names.size(); ++i) {
    double share = 0;
    for (int c = 0; c < a.uncertainty.considered_column_sigma.size(); ++c) {
      share += std::pow(
          a.uncertainty.considered_sensitivity(i, c) * a.uncertainty.considered_column_sigma(c), 2);
    }
    EXPECT_NEAR(a.uncertainty.sigma(i) * a.uncertainty.sigma(i),
                a.uncertainty.noise_sigma(i) * a.uncertainty.noise_sigma(i) + share,
                1e-6 * a.uncertainty.sigma(i) * a.uncertainty.sigma(i))
        << a.estimate.names[i];
  }
}

// The same for a lip edge moved as a whole (mirror 1's lip seen in mirror 1, every image): its
// u, v columns.
TEST(CalibConsidered, LipEdgeMoveSensitivityMatchesSolvingAgain) {
  testing::SyntheticSession session;
  const RigParams truth = testing::SmallCleanSessionWithoutTangential(&session);
  Observations detections = testing::NoisyDetections(session, 0.01, 7);
  testing::AddLipDetections(truth, 0.05, 11, &detections, 90);
  const Eigen::Vector2d offset(0.005, -0.0075);
  Observations moved = detections;
  std::string column;
  for (auto& image : moved.images) {
    for (auto& edge : image.lips) {
      if (edge.path != LipPath::kViaMirror1) continue;
      for (auto& p : edge.points) p += offset;
      char name[64];
      const Lip& lip = LipOf(truth, *edge.path);
      std::snprintf(name, sizeof(name), "lip %s r %g", LipPathName(*edge.path),
                    *edge.circle == LipCircle::kInner ? lip.r_inner : lip.r_outer);
      column = name;
    }
  }
  ASSERT_FALSE(column.empty());
  ExpectMoveAsPredicted(truth, session.targets, detections, moved, column, offset);
}

}  // namespace
}  // namespace omni::calib
