// Calibration from exact synthetic observations plus known pixel noise (the fast path): the
// misaligned rig is recovered within 3 sigma from the ideal starting model, the residual RMS
// matches the noise, and the calibrated model projects like the true one.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <Eigen/Geometry>

#include "calib/calibrate.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

using testing::IdealRig;
using testing::MisalignedRig;

// The misaligned rig without lens distortion, refining camera + misalignment: every reported
// parameter lands within 3 sigma of the truth and the residual RMS matches the noise.
TEST(CalibRecovery, MisalignedRigWithinThreeSigma) {
  RigParams truth = MisalignedRig();
  truth.distortion = {0, 0, 0, 0, 0};
  synthetic::RandomPlacement random;
  random.images = 12;
  random.targets_min = 2;
  random.targets_max = 3;
  random.range_min_mm = 500;
  random.range_max_mm = 2000;
  random.max_tilt_rad = 0.35;
  random.seed = 11;
  const auto session = testing::MakeSession(truth, random, {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0), testing::Chessboard(6, 8, 40.0)});
  const double noise_px = 0.3;
  const Observations detections = testing::NoisyDetections(session, noise_px, 5);

  CalibrationOptions options;
  options.estimate = {"camera", "mirror1_pose", "mirror2_pose", "reflex"};
  options.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  const auto t0 = std::chrono::steady_clock::now();
  const CalibrationResult result = Calibrate(IdealRig(), session.targets, detections, options);
  std::fprintf(stderr, "solve %.2f s\n%s", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
               ResultTable(result, &truth).c_str());

  EXPECT_TRUE(result.solve.converged);
  // The camera's rotation against the mirror bodies is nearly a gauge (it shows as a principal
  // point shift plus second-order terms), so cx, cy and the mirror tilts may be named as nearly
  // unobservable at this noise; whatever is reported must hold.
  for (const auto& u : result.uncertainty.unobservable) EXPECT_FALSE(u.hint.empty()) << u.name;
  // RMS of 2-D residuals with sigma per axis: sqrt(2) sigma, less the fitted parameters' share.
  EXPECT_NEAR(result.residuals.rms_px, std::sqrt(2.0) * noise_px, 0.2 * std::sqrt(2.0) * noise_px);
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    const double t = testing::TruthValue(truth, result.estimate.names[i]);
    EXPECT_LT(std::abs(result.estimate.values(i) - t), 3 * result.uncertainty.sigma(i))
        << result.estimate.names[i] << " = " << result.estimate.values(i) << " truth " << t
        << " sigma " << result.uncertainty.sigma(i);
  }
}

// With the sample rig's lens distortion and the default groups, corners in the stereo band alone
// cannot separate the focal length, radial distortion and the mirrors' axial positions: the
// calibration must name what it cannot determine, and what it reports must hold (3 sigma).
TEST(CalibRecovery, DistortedRigNamesWhatItCannotDetermine) {
  const RigParams truth = MisalignedRig();
  synthetic::RandomPlacement random;
  random.images = 12;
  random.targets_min = 2;
  random.targets_max = 3;
  random.seed = 11;
  const auto session = testing::MakeSession(truth, random, {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0), testing::Chessboard(6, 8, 40.0)});
  const CalibrationResult result = Calibrate(IdealRig(), session.targets,
                                             testing::NoisyDetections(session, 0.3, 5), {});
  std::fprintf(stderr, "%s", ResultTable(result, &truth).c_str());
  EXPECT_FALSE(result.uncertainty.unobservable.empty());
  for (const auto& u : result.uncertainty.unobservable) EXPECT_FALSE(u.hint.empty()) << u.name;
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    const double t = testing::TruthValue(truth, result.estimate.names[i]);
    EXPECT_LT(std::abs(result.estimate.values(i) - t), 3 * result.uncertainty.sigma(i))
        << result.estimate.names[i];
  }
}

}  // namespace
}  // namespace omni::calib
