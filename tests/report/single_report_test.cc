// The calibration report of a single-mirror camera (rig: single; one ring, no stereo): a
// paraboloid behind a telecentric lens, fast path (exact corners + 0.3 px):
// - the page speaks of one ring: the projection uncertainty over the ring's view (not a stereo
//   band it does not have), a map for each range, no triangulation table, no ring 2;
// - the coverage advice reads the ring's own elevations: every corner kept below the middle of
//   the ring's view at 1 m is told to add targets higher, the whole session is not.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "calib/calibrate.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "report/report.h"
#include "tests/calib/calib_test_util.h"
#include "tests/io/io_test_util.h"

namespace omni::report {
namespace {

namespace fs = std::filesystem;

RigParams Truth() {
  RigParams truth = MakeSingleRig(Conic<double>{16.0, -1.0}, LensKind::kTelecentric, 60, 30, 4,
                                  Pinhole<double>{13.3, 13.3, 640, 512, 0}, 1280, 1024);
  truth.kind = ModelKind::kNoncentral;
  truth.mirror1_pose = {0.01, -0.007, 0, 0, 0};
  return truth;
}

double Elevation(const RigModel& model, const Eigen::Vector2d& pixel) {
  const auto ray = model.Unproject(pixel);
  if (!ray) return NAN;
  const Eigen::Vector3d& d = ray->ray.direction;
  return std::atan2(d.z(), d.head<2>().norm()) * 180 / M_PI;
}

struct Solved {
  testing::SyntheticSession session;
  Observations detections;
  calib::CalibrationResult result;
};

Solved Solve(double below_deg) {
  Solved s;
  synthetic::RandomPlacement random;
  random.images = 12;
  random.targets_min = 2;
  random.targets_max = 2;
  random.range_min_mm = 250;
  random.range_max_mm = 1000;
  random.max_tilt_rad = 0.35;
  random.seed = 21;
  const RigParams truth = Truth();
  s.session = testing::MakeSession(truth, random,
                                   {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0)});
  s.detections = testing::NoisyDetections(s.session, 0.3, 7);
  const RigModel model(truth);
  for (auto& image : s.detections.images) {
    std::vector<CornerObservation> kept;
    for (const auto& c : image.corners) {
      if (Elevation(model, c.pixel) < below_deg) kept.push_back(c);
    }
    image.corners = kept;
  }
  calib::CalibrationOptions options;
  options.estimate = {"camera", "distortion", "mirror1_shape", "mirror1_pose"};
  options.profile = "off";
  options.use_lips = false;
  s.result = calib::Calibrate(truth, s.session.targets, s.detections, options);
  return s;
}

ReportInput InputOf(const Solved& s) {
  ReportInput in;
  in.result = &s.result;
  in.observations = &s.detections;
  in.targets = s.session.targets;
  in.session = "synthetic single";
  return in;
}

TEST(SingleReport, OneRingsProjectionUncertaintyAndNoTriangulation) {
  const Solved s = Solve(90);
  const std::string dir = (fs::temp_directory_path() / "omni_single_report_test").string();
  fs::remove_all(dir);
  const std::string html = testing::ReadText(WriteReport(dir, InputOf(s)));
  ASSERT_FALSE(html.empty());
  const size_t projection = html.find("<h2>Projection uncertainty</h2>");
  const size_t correlations = html.find("<h2>Strongest correlations</h2>");
  ASSERT_NE(projection, std::string::npos);
  ASSERT_NE(correlations, std::string::npos);
  const std::string section = html.substr(projection, correlations - projection);
  std::fprintf(stderr, "%s\n", section.c_str());
  EXPECT_NE(section.find("over the ring's view at 1 m"), std::string::npos);
  EXPECT_EQ(section.find("ring 2"), std::string::npos);
  EXPECT_EQ(section.find("stereo band"), std::string::npos);
  EXPECT_NE(section.find("nothing is triangulated from one photo"), std::string::npos);
  // Both maps drawn (1 m and the far range), no "missing figure" note.
  EXPECT_TRUE(fs::exists(dir + "/uncertainty_1000mm.png"));
  EXPECT_EQ(html.find("class=\"missing\""), std::string::npos);
  for (const std::string& a : Advice(InputOf(s))) {
    std::fprintf(stderr, "advice (whole session): %s\n", a.c_str());
    EXPECT_EQ(a.find("add targets higher"), std::string::npos) << a;
  }
  fs::remove_all(dir);
}

TEST(SingleReport, AdviceAsksForHigherTargetsWhereTheSessionHasNone) {
  const RigModel model(Truth());
  double lo = 1e9, hi = -1e9;
  for (const BandPoint& p : StereoBandPoints(model, 1000)) {
    const double e = Elevation(model, p.pixel[0]);
    if (std::isfinite(e)) lo = std::min(lo, e), hi = std::max(hi, e);
  }
  ASSERT_LT(lo, hi);
  const Solved s = Solve(0.5 * (lo + hi));
  bool asked = false;
  for (const std::string& a : Advice(InputOf(s))) {
    std::fprintf(stderr, "advice (no high corners): %s\n", a.c_str());
    asked |= a.find("add targets higher") != std::string::npos;
  }
  EXPECT_TRUE(asked);
}

}  // namespace
}  // namespace omni::report
