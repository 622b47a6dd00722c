// The model file's calibration: section as a calibration writes it (unobservable parameters with
// hints, rejected count, lip statistics besides the covariance) reads back unchanged; a hint list
// that does not match the names is refused with one line.
#include <gtest/gtest.h>

#include "calib/calibrate.h"
#include "io/file_util.h"
#include "io/model_file.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

TEST(CalibModelFile, CalibrationSectionRoundTrip) {
  const RigParams truth = testing::MisalignedRig();
  synthetic::RandomPlacement random;
  random.images = 6;
  random.targets_min = 2;
  random.targets_max = 3;
  random.seed = 11;
  const auto session = testing::MakeSession(
      truth, random, {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0), testing::Chessboard(6, 8, 40.0)});
  Observations d = testing::NoisyDetections(session, 0.3, 5);
  testing::AddLipDetections(truth, 0.3, 7, &d, 90);
  d.images[0].corners[0].pixel += Eigen::Vector2d(25, 0);  // one outlier
  const CalibrationResult result = Calibrate(testing::IdealRig(), session.targets, d, {});
  ASSERT_TRUE(result.estimate.rig.calibration);
  const CalibrationInfo& a = *result.estimate.rig.calibration;
  EXPECT_GE(a.n_rejected, 1);
  EXPECT_GT(a.n_lip_points, 0);
  EXPECT_EQ(a.unobservable.size(), result.uncertainty.unobservable.size());

  const std::string text = io::ModelFileText(result.estimate.rig);
  const RigParams back = io::ParseModelText(text, "calibrated.yaml");
  ASSERT_TRUE(back.calibration);
  const CalibrationInfo& b = *back.calibration;
  EXPECT_EQ(b.parameters, a.parameters);
  EXPECT_EQ(b.unobservable, a.unobservable);
  EXPECT_EQ(b.unobservable_hints, a.unobservable_hints);
  EXPECT_EQ(b.n_rejected, a.n_rejected);
  EXPECT_EQ(b.n_lip_points, a.n_lip_points);
  EXPECT_NEAR(b.lip_rms_px, a.lip_rms_px, 1e-9 * (1 + a.lip_rms_px));
  ASSERT_EQ(b.covariance.size(), a.covariance.size());
  for (size_t i = 0; i < a.covariance.size(); ++i) {
    EXPECT_NEAR(b.covariance[i], a.covariance[i], 1e-9 * std::abs(a.covariance[i]) + 1e-300);
  }

  // Hints that do not match the names: one line naming the field.
  RigParams bad = result.estimate.rig;
  bad.calibration->unobservable = {"fx"};
  bad.calibration->unobservable_hints = {"a", "b"};
  try {
    io::ParseModelText(io::ModelFileText(bad), "bad.yaml");
    ADD_FAILURE() << "accepted mismatched hints";
  } catch (const io::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("unobservable_hints"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace omni::calib
