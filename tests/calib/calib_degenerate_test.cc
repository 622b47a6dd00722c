// Bad input for the calibration: each ends in one CalibrationError (or io::InputError) whose
// message names the cause, before any model is produced.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "calib/calibrate.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

testing::SyntheticSession Session(double range_min, double range_max, int images, unsigned seed,
                                  int targets_per_image = 3) {
  synthetic::RandomPlacement random;
  random.images = images;
  random.targets_min = targets_per_image;
  random.targets_max = targets_per_image;
  random.range_min_mm = range_min;
  random.range_max_mm = range_max;
  random.seed = seed;
  return testing::MakeSession(testing::MisalignedRig(), random,
                              {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0), testing::Chessboard(6, 8, 40.0)});
}

std::string ErrorOf(const Observations& detections, const std::vector<TargetSpec>& targets) {
  try {
    CalibrationOptions options;
    options.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
    Calibrate(testing::IdealRig(), targets, detections, options);
  } catch (const CalibrationError& e) {
    return std::string("CalibrationError: ") + e.what();
  } catch (const io::InputError& e) {
    return std::string("InputError: ") + e.what();
  }
  return "no error";
}

TEST(CalibDegenerate, TooFewObservations) {
  const auto session = Session(500, 2000, 1, 21, 2);
  const std::string error = ErrorOf(testing::NoisyDetections(session, 0.2, 1), session.targets);
  EXPECT_NE(error.find("CalibrationError: too few observations"), std::string::npos) << error;
}

// Keeps the placements whose centre (horizontal range rho, azimuth az about the axis) passes.
Observations Filtered(const testing::SyntheticSession& session,
                        const std::function<bool(double rho, double az)>& keep_centre,
                        int* kept_placements) {
  Observations detections = testing::NoisyDetections(session, 0.2, 1);
  *kept_placements = 0;
  for (size_t i = 0; i < detections.images.size(); ++i) {
    const auto& placements = session.scene.images[i].placements;
    std::vector<bool> keep(session.targets.size(), false);
    std::vector<int> count(session.scene.targets.size(), 0);
    for (const auto& p : placements) {
      const TargetSpec& spec = session.scene.targets[p.target];
      const int target =
          p.target + static_cast<int>(session.scene.targets.size()) * count[p.target]++;
      const Eigen::Vector3d c =
          p.cam_from_target_rotation *
              (0.5 * (CornerInTarget(spec, 0) + CornerInTarget(spec, CornerCount(spec) - 1))) +
          p.cam_from_target_translation;
      keep[target] = keep_centre(std::hypot(c.x(), c.y()), std::atan2(c.y(), c.x()));
      *kept_placements += keep[target];
    }
    std::vector<CornerObservation> kept;
    for (const auto& c : detections.images[i].corners) {
      if (keep[c.target]) kept.push_back(c);
    }
    detections.images[i].corners = kept;
  }
  return detections;
}

TEST(CalibDegenerate, AllTargetsAtOneRange) {
  const auto session = Session(500, 2000, 30, 22);
  int kept = 0;
  const Observations detections =
      Filtered(session, [](double rho, double) { return rho > 900 && rho < 1100; }, &kept);
  ASSERT_GE(kept, 3);
  const std::string error = ErrorOf(detections, session.targets);
  EXPECT_NE(error.find("all targets at one range"), std::string::npos) << error;
}

TEST(CalibDegenerate, AllTargetsInOneAzimuthSector) {
  const auto session = Session(500, 2000, 30, 23);
  int kept = 0;
  const Observations detections =
      Filtered(session, [](double, double az) { return std::abs(az) < 30 * M_PI / 180; }, &kept);
  ASSERT_GE(kept, 3);
  const std::string error = ErrorOf(detections, session.targets);
  EXPECT_NE(error.find("all targets in one azimuth sector"), std::string::npos) << error;
}

TEST(CalibDegenerate, TargetSpecMatchingNothing) {
  const auto session = Session(500, 2000, 3, 24);
  Observations detections = testing::NoisyDetections(session, 0.2, 1);
  for (auto& image : detections.images) image.corners.clear();  // what a wrong rows x cols gives
  const std::string error = ErrorOf(detections, session.targets);
  EXPECT_NE(error.find("match nothing"), std::string::npos) << error;
}

TEST(CalibDegenerate, CornerOfAnUnknownTarget) {
  const auto session = Session(500, 2000, 3, 25);
  Observations detections = testing::NoisyDetections(session, 0.2, 1);
  detections.images[0].corners[0].target = 99;
  const std::string error = ErrorOf(detections, session.targets);
  EXPECT_NE(error.find("InputError: "), std::string::npos) << error;
  EXPECT_NE(error.find("target index 99"), std::string::npos) << error;
}

TEST(CalibDegenerate, UnknownEstimateGroup) {
  const auto session = Session(500, 2000, 3, 26);
  CalibrationOptions options;
  options.estimate = {"camera", "lens_shift"};
  EXPECT_THROW(Calibrate(testing::IdealRig(), session.targets,
                         testing::NoisyDetections(session, 0.2, 1), options),
               io::InputError);
}

}  // namespace
}  // namespace omni::calib
