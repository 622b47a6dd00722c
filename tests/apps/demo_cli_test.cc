// `omnistereo demo` end to end, as README's first command runs it: POV-Ray renders of the
// misaligned big rig, the detectors, the calibration from the ideal design. Issue #6's acceptance
// on renders, against the truth the renders were made from (model.yaml, truth.yaml):
//   - each ring's reprojection RMS within 20% of the detector's true corner error (printed by
//     `calibrate --truth`);
//   - every misalignment parameter within 3 sigma of the truth (calibrated.yaml's calibration:);
//   - the calibrated model projects like the true one over both rings' stereo band at 1 m to
//     <= 0.1 px RMS per ring with the points held in mirror 1's body (the rig's frame; the camera
//     frame's pointing is what the lens's held dist_p1, dist_p2 leave open), where the ideal
//     model is 7-14 px off (issue 16's acceptance). The demo's images come from a realistic
//     colour camera (demo_scene.yaml); with the blurred-junction corner fits the detector's true
//     error is ~0.03 / 0.05 px in ring 1 / 2 there, and this figure carries mirror 1's tilt
//     noise, which grows with it: measured 0.078 / 0.040 px (0.17 / 0.09 with the cornerSubPix
//     corners, 0.11 px in ring 2).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "io/model_file.h"
#include "model/model_compare.h"
#include "tests/calib/calib_test_util.h"
#include "tests/cli_test_util.h"
#include "tests/report/browser_check.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

TEST(DemoCli, CalibratesTheRenderedRigWithinItsSigma) {
  const fs::path dir = fs::temp_directory_path() / ("omni_demo_cli_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  std::string err, out;
  ASSERT_EQ(testing::RunOmnistereo("demo --out='" + dir.string() + "'", dir.string() + ".err", &err,
                                   dir.string() + ".out", &out),
            0)
      << err << out;

  for (int ring = 1; ring <= 2; ++ring) {
    testing::CornerNoiseLine line;
    ASSERT_TRUE(testing::ParseCornerNoiseLine(out, ring, &line)) << out;
    std::printf("ring %d: residual %.4f px, true corner error %.4f px over %d corners\n", ring,
                line.residual_px, line.true_error_px, line.corners);
    EXPECT_GT(line.corners, 500);
    EXPECT_NEAR(line.residual_px / line.true_error_px, 1.0, 0.2);
  }

  const RigParams truth = io::ReadModelFile((dir / "model.yaml").string());
  const RigParams calibrated = io::ReadModelFile((dir / "calibrated.yaml").string());
  const RigParams nominal = io::ReadModelFile((dir / "nominal.yaml").string());
  ASSERT_TRUE(calibrated.calibration.has_value());
  const CalibrationInfo& info = *calibrated.calibration;
  int misalignment = 0;
  for (size_t i = 0; i < info.parameters.size(); ++i) {
    const std::string& name = info.parameters[i];
    if (!testing::IsMisalignment(name)) continue;
    ++misalignment;
    const double t = testing::TruthValue(truth, name);
    const double off = std::abs(info.values[i] - t) / info.sigma[i];
    std::printf("%-12s %+.6f truth %+.6f: %.2f sigma\n", name.c_str(), info.values[i], t, off);
    EXPECT_LT(off, 3.0) << name;
  }
  EXPECT_EQ(misalignment, 13);
  for (const std::string& name : info.unobservable) {
    EXPECT_FALSE(testing::IsMisalignment(name)) << name << " named unobservable";
  }

  const RigModel true_model(truth);
  const ProjectionDifference ideal =
      CompareProjectionsInMirror1(true_model, RigModel(nominal), 1000);
  const ProjectionDifference gained =
      CompareProjectionsInMirror1(true_model, RigModel(calibrated), 1000);
  std::printf("at 1 m in mirror 1's body: ideal %.3f / %.3f px, calibrated %.3f / %.3f px\n",
              ideal.rms_px[0], ideal.rms_px[1], gained.rms_px[0], gained.rms_px[1]);
  EXPECT_GT(gained.points, 1000);
  for (int m = 0; m < 2; ++m) {
    EXPECT_GT(ideal.rms_px[m], 3.0);
    EXPECT_LE(gained.rms_px[m], 0.1);
  }
  // The demo's report (calibrate --report) in a browser: its 8 figures (and any outlier
  // thumbnails), all loading.
  testing::CheckReportInBrowser((dir / "report").string(), 8);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".err");
  fs::remove(dir.string() + ".out");
}

}  // namespace
}  // namespace omni
