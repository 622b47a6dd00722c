// The report's measured-profile figure (report/figures.h MeasuredProfilePlot): a calibration
// started from scans of both mirrors (tests/calib/measured_profile_util.h, real files) on 12
// random images of chessboards (fast path, 0.1 px), mirror 2's scan then dropped. The plotted curves are checked against the
// profile formula evaluated independently from the fit's and the calibrated coefficients; the
// page shows one figure per measured mirror and none for a mirror without a scan.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "calib/calibrate.h"
#include "report/figures.h"
#include "report/report.h"
#include "tests/calib/calib_test_util.h"
#include "tests/calib/measured_profile_util.h"
#include "tests/temp_dir.h"

namespace omni::report {
namespace {

namespace fs = std::filesystem;

// The rows of datablock `name` in a gnuplot script.
std::vector<std::vector<double>> Rows(const std::string& script, const std::string& name) {
  std::istringstream in(script.substr(script.find("$" + name + " << EOD\n")));
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line) && line != "EOD") {
    std::istringstream fields(line);
    std::vector<double> row;
    for (double v; fields >> v;) row.push_back(v);
    rows.push_back(row);
  }
  return rows;
}

double SagUm(const std::array<double, kProfileTerms>& coeffs, const ProfileShape& shape, double r) {
  ProfileShape no_ripple = shape;
  no_ripple.ripple_amplitude = 0;
  return 1000 * ProfileSag(coeffs.data(), no_ripple, r, 0.0, false).z;  // the first line: 0 deg
}

TEST(ProfileFigure, PlotsTheMeasuredAndCalibratedProfilesAndTheirDifference) {
  const fs::path dir = testing::UniqueTempDir("report_profile");
  const RigParams truth = testing::ProfiledTruth(0.010);
  synthetic::RandomPlacement random;
  random.images = 12;
  random.targets_min = 2;
  random.targets_max = 3;
  random.range_min_mm = 400;
  random.range_max_mm = 2500;
  random.max_tilt_rad = 0.35;
  random.seed = 23;
  const testing::SyntheticSession session = testing::MakeSession(
      truth, random,
      {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0), testing::Chessboard(7, 9, 30.0)});
  Observations detections = testing::NoisyDetections(session, 0.1, 5);
  RigParams start = testing::StartWithScans(dir / "model", truth);
  start.measured_profile[1].reset();  // mirror 2 as if not measured: the machining tolerance
  const calib::CalibrationResult result =
      calib::Calibrate(start, session.targets, detections, calib::CalibrationOptions());
  ASSERT_TRUE(result.residuals.profile[0].measured);
  ASSERT_FALSE(result.residuals.profile[1].measured);
  EXPECT_EQ(MeasuredProfileScript(result, 2), "");

  const std::string script = MeasuredProfileScript(result, 1);
  const RigParams& cal = result.estimate.rig;
  const MeasuredProfile& measured = *cal.measured_profile[0];
  // The scan's first line (0 deg), its piston removed.
  const auto points = Rows(script, "points");
  size_t first_line = 0;
  while (first_line < measured.scan.size() && measured.scan[first_line].theta_rad == 0) ++first_line;
  ASSERT_EQ(points.size(), first_line);
  EXPECT_NEAR(points[0][0], measured.scan[0].r_mm, 1e-6);  // 9 digits
  EXPECT_NEAR(points[0][1], 1000 * (measured.scan[0].sag_mm - measured.fit.piston_mm), 1e-6);
  const auto curves = Rows(script, "curves");
  ASSERT_EQ(curves.size(), 121u);
  EXPECT_NEAR(curves.front()[0], cal.profile1.r_min, 1e-6);
  EXPECT_NEAR(curves.back()[0], cal.profile1.r_max, 1e-6);
  double largest_sigma = 0;
  for (const auto& row : curves) {
    EXPECT_NEAR(row[1], SagUm(measured.fit.coeffs, cal.profile1, row[0]), 1e-6);
    EXPECT_NEAR(row[2], SagUm(cal.mirror1_profile, cal.profile1, row[0]), 1e-6);
    EXPECT_NEAR(row[3], row[2] - row[1], 1e-6);
    EXPECT_GE(row[4], 0);
    largest_sigma = std::max(largest_sigma, row[4]);
  }
  // The band is the difference's: under the prior's own spread (the scan's fit, ~0.1-0.2 um per
  // term) and not zero, the profile being refined.
  EXPECT_GT(largest_sigma, 0.01);
  EXPECT_LT(largest_sigma, 1.0);

  // A calibrated model read back carries the fit without the points: the figure still draws.
  calib::CalibrationResult without_points = result;
  without_points.estimate.rig.measured_profile[0]->scan.clear();
  const std::string fit_only = MeasuredProfileScript(without_points, 1);
  EXPECT_EQ(fit_only.find("$points"), std::string::npos);
  EXPECT_EQ(Rows(fit_only, "curves"), curves);

  ReportInput in;
  in.result = &result;
  in.observations = &detections;
  in.targets = session.targets;
  in.session = "synthetic";
  const std::string index = WriteReport((dir / "report").string(), in);
  std::ifstream page(index);
  const std::string html((std::istreambuf_iterator<char>(page)), std::istreambuf_iterator<char>());
  EXPECT_EQ(html.find("profile_mirror2"), std::string::npos);
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) GTEST_SKIP() << "no gnuplot";
  EXPECT_NE(html.find("<img src=\"profile_mirror1.png\""), std::string::npos);
  EXPECT_GT(fs::file_size(dir / "report" / "profile_mirror1.png"), 10000u);
  in.result = &without_points;
  std::string note;
  fs::create_directories(dir / "fit_only");
  EXPECT_EQ(MeasuredProfilePlot((dir / "fit_only").string(), in, 1, &note), "profile_mirror1.png")
      << note;
}

}  // namespace
}  // namespace omni::report
