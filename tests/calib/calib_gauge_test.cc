// Is the principal-point-vs-rotation weakness an exact gauge of the parameterisation or only
// weak data? On exact synthetic corners (no noise) the Jacobi-scaled Schur complement of the
// rig parameters (target poses eliminated) is analysed at the truth: an exact gauge would show
// an eigenvalue at round-off level (~1e-16 of the largest). Prints the weakest directions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numeric>

#include "calib/calibrate.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

void PrintWeakest(const CalibrationResult& r, int count) {
  const double largest = r.uncertainty.schur_eigenvalues.maxCoeff();
  for (int k = 0; k < std::min<int>(count, r.uncertainty.schur_eigenvalues.size()); ++k) {
    std::fprintf(stderr, "eigenvalue/largest %.3e:", r.uncertainty.schur_eigenvalues(k) / largest);
    std::vector<int> idx(r.uncertainty.refined_names.size());
    std::iota(idx.begin(), idx.end(), 0);
    std::sort(idx.begin(), idx.end(), [&](int a, int b) {
      return std::abs(r.uncertainty.schur_eigenvectors(a, k)) >
             std::abs(r.uncertainty.schur_eigenvectors(b, k));
    });
    for (int j = 0; j < 6; ++j) {
      std::fprintf(stderr, " %s %+.2f", r.uncertainty.refined_names[idx[j]].c_str(),
                   r.uncertainty.schur_eigenvectors(idx[j], k));
    }
    std::fprintf(stderr, "\n");
  }
}

CalibrationResult Analyse(const RigParams& truth, const std::vector<std::string>& groups,
                          bool lips) {
  synthetic::RandomPlacement random;
  random.images = 12;
  random.targets_min = 2;
  random.targets_max = 3;
  random.seed = 11;
  const auto session = testing::MakeSession(
      truth, random,
      {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0),
       testing::Chessboard(6, 8, 40.0)});
  Observations d = testing::NoisyDetections(session, 0.0, 1);
  if (lips) testing::AddLipDetections(truth, 0.0, 1, &d, 180);
  CalibrationOptions options;
  options.estimate = groups;
  options.use_lips = lips;
  return Calibrate(truth, session.targets, d, options);  // from the truth: exact data, exact fit
}

TEST(CalibGauge, NoExactGaugeOnlyWeakDirections) {
  RigParams undistorted = testing::MisalignedRig();
  undistorted.distortion = {0, 0, 0, 0, 0};
  struct Case {
    const char* what;
    RigParams truth;
    std::vector<std::string> groups;
    bool lips;
  } cases[] = {
      {"no distortion, camera + poses, corners", undistorted,
       {"camera", "mirror1_pose", "mirror2_pose", "reflex"}, false},
      {"sample distortion, all default groups, corners", testing::MisalignedRig(),
       {"camera", "distortion", "mirror1_pose", "mirror2_pose", "reflex"}, false},
      {"sample distortion, all default groups, corners + lips", testing::MisalignedRig(),
       {"camera", "distortion", "mirror1_pose", "mirror2_pose", "reflex"}, true},
  };
  for (const Case& c : cases) {
    const CalibrationResult r = Analyse(c.truth, c.groups, c.lips);
    std::fprintf(stderr, "--- %s (rms %.2e px)\n", c.what, r.residuals.rms_px);
    PrintWeakest(r, 3);
    const double ratio =
        r.uncertainty.schur_eigenvalues(0) / r.uncertainty.schur_eigenvalues.maxCoeff();
    // Far above round-off: weak data, not a gauge of the parameterisation.
    EXPECT_GT(ratio, 1e-10) << c.what;
  }
}

}  // namespace
}  // namespace omni::calib
