// Predicted uncertainty vs Monte Carlo: the same synthetic session (fixed target placements, the
// misaligned big rig as truth) with fresh Gaussian pixel noise of known sigma each time, solved
// from the ideal model. The spread of each misalignment parameter over the solves must match the
// sigma the calibration predicts (Schur-complement covariance scaled by the posterior variance
// factor) within 20%, and the predicted sigma must match the truth's error scale.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <thread>

#include "calib/calibrate.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

// DISABLED: not met yet. Measured (60 solves, 8 images, 1546 observations, 0.2 px noise, 101 s
// wall on a loaded 2-core machine): spread/predicted 0.63..1.08; within 20% for mirror1.ry,
// mirror1.tz, mirror2.ry, mirror2.tx, mirror2.tz; 0.63..0.79 for mirror1.rx/tx/ty, mirror2.rx/ty,
// reflex.rx/dz; cx, cy and several tilts were named nearly unobservable in part of the solves
// (the camera-rotation near-gauge). Run with --gtest_also_run_disabled_tests; MC_SOLVES,
// MC_IMAGES, MC_RMIN override the size.
// Re-measured after the tighter solver tolerances (calib2; 30 solves, 13 s): ratios 0.73..1.56
// (mirror1.ry 1.44, mirror2.ry 1.56, reflex.dz 0.73, fx 0.67); cx named unobservable in 18 of 30
// solves, mirror1 tilts in 10, mirror2 tilts in 17-18: the parameter sets compared differ per
// solve. Note: with 60 solves the sampling sd of a spread/predicted ratio is ~9%, so a 20% bar
// over 13 parameters fails by chance ~30% of the time even with an exact covariance.
TEST(CalibMonteCarlo, DISABLED_PredictedSigmaMatchesSpread) {
  // The misaligned rig without lens distortion, calibrated for camera + misalignment: with only
  // corners in the stereo band, radial distortion trades with the focal length and the mirrors'
  // axial positions (see calib_recovery_test), which is not what this test is about.
  RigParams truth = testing::MisalignedRig();
  truth.distortion = {0, 0, 0, 0, 0};
  synthetic::RandomPlacement random;
  random.images = std::getenv("MC_IMAGES") ? std::atoi(std::getenv("MC_IMAGES")) : 8;
  random.targets_min = 2;
  random.targets_max = 3;
  random.range_min_mm = std::getenv("MC_RMIN") ? std::atof(std::getenv("MC_RMIN")) : 400;
  random.range_max_mm = 2000;
  random.max_tilt_rad = 0.35;
  random.seed = 3;
  const auto session = testing::MakeSession(
      truth, random, {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0), testing::Chessboard(6, 8, 40.0)});
  const double noise_px = 0.2;
  const int solves = std::getenv("MC_SOLVES") ? std::atoi(std::getenv("MC_SOLVES")) : 60;

  std::vector<CalibrationResult> results(solves);
  auto run = [&](int first, int step) {
    for (int k = first; k < solves; k += step) {
      CalibrationOptions options;
      options.solver.threads = 1;
      options.estimate = {"camera", "mirror1_pose", "mirror2_pose", "reflex"};
      results[k] = Calibrate(testing::IdealRig(), session.targets,
                             testing::NoisyDetections(session, noise_px, 1000 + k), options);
    }
  };
  std::thread worker(run, 1, 2);
  run(0, 2);
  worker.join();
  std::fprintf(stderr, "%s", ResultTable(results[0], &truth).c_str());

  std::map<std::string, std::vector<double>> values, sigmas;
  for (const auto& r : results) {
    for (size_t i = 0; i < r.names.size(); ++i) {
      values[r.names[i]].push_back(r.values(i));
      sigmas[r.names[i]].push_back(r.sigma(i));
    }
  }
  for (const auto& [name, v] : values) {
    double mean = 0, predicted = 0;
    for (double x : v) mean += x / v.size();
    for (double s : sigmas[name]) predicted += s / v.size();
    double var = 0;
    for (double x : v) var += (x - mean) * (x - mean) / (v.size() - 1);
    const double spread = std::sqrt(var);
    std::fprintf(stderr, "%-12s n %3zu  spread %.6g  predicted %.6g  ratio %.3f\n", name.c_str(),
                 v.size(), spread, predicted, spread / predicted);
    if (name.rfind("mirror", 0) == 0 || name.rfind("reflex", 0) == 0) {
      EXPECT_EQ(v.size(), static_cast<size_t>(solves)) << name << " was named unobservable";
      EXPECT_NEAR(spread / predicted, 1.0, 0.2) << name;
    }
  }
}

}  // namespace
}  // namespace omni::calib
