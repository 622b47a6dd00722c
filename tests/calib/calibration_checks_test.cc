// calib/calibration_checks.h and calib/monte_carlo.h's noise on hand-made results, detections and
// truths whose answers are computed by hand.
#include "calib/calibration_checks.h"

#include <cmath>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "calib/monte_carlo.h"

namespace omni::calib {
namespace {

CornerObservation Corner(int target, int id, Mirror mirror, double u, double v) {
  CornerObservation c;
  c.target = target;
  c.id = id;
  c.mirror = mirror;
  c.pixel = Eigen::Vector2d(u, v);
  return c;
}

TruthCorner True(int target, int id, const Eigen::Vector2d& ring1,
                 std::optional<Eigen::Vector2d> ring2 = std::nullopt) {
  TruthCorner t;
  t.target = target;
  t.id = id;
  t.pixel[0] = ring1;
  t.pixel[1] = ring2;
  return t;
}

TEST(CalibrationChecks, CornerNoiseOverTheKeptCornersMatchedByFileName) {
  Truth truth;
  truth.images.resize(1);
  truth.images[0].file = "a.png";  // the detections name it by path
  truth.images[0].corners = {True(0, 0, {10, 10}, Eigen::Vector2d(100, 100)),
                             True(0, 1, {20, 20})};
  Observations detections;
  detections.images.resize(1);
  detections.images[0].file = "session/a.png";
  detections.images[0].corners = {Corner(0, 0, Mirror::kOne, 10.3, 10.4),   // 0.5 px
                                  Corner(0, 1, Mirror::kOne, 20, 21),       // 1 px
                                  Corner(0, 0, Mirror::kTwo, 100, 102),     // left out
                                  Corner(0, 5, Mirror::kOne, 10, 10)};      // no true id 5
  CalibrationResult result;
  RejectedObservation left_out;
  left_out.image = 0;
  left_out.target = 0;
  left_out.id = 0;
  left_out.mirror = 2;
  result.residuals.rejected = {left_out};
  const CornerNoise noise = CornerNoiseAgainstTruth(result, detections, truth);
  EXPECT_EQ(noise.count[0], 2);
  EXPECT_EQ(noise.count[1], 0);
  EXPECT_EQ(noise.unmatched, 1);
  EXPECT_NEAR(noise.true_rms_px[0], std::sqrt((0.25 + 1.0) / 2), 1e-12);
  EXPECT_EQ(noise.true_rms_px[1], 0);
}

TEST(CalibrationChecks, LeftOutLinesAndTheirSummaryPerTarget) {
  Observations detections;
  detections.images.resize(2);
  detections.images[0].file = "0001.png";
  detections.images[1].file = "0002.png";
  CalibrationResult result;
  EXPECT_EQ(LeftOutText(result, detections, {}), "");
  RejectedObservation a;
  a.image = 1;
  a.target = 0;
  a.id = 7;
  a.mirror = 2;
  a.pixel = Eigen::Vector2d(1.5, 2.25);
  a.residual_px = 0.375;
  a.reason = "outlier";
  RejectedObservation b = a;
  b.image = 0;
  b.residual_px = 0;
  b.reason = "not projectable";
  result.residuals.rejected = {a, b};
  TargetSpec board;
  board.type = TargetType::kChessboard;
  board.rows = 6;
  board.cols = 8;
  EXPECT_EQ(LeftOutText(result, detections, {board}),
            "left out: image 1 (0002.png) target 0 corner 7 ring 2 at (1.50, 2.25): outlier (0.38 px)\n"
            "left out: image 0 (0001.png) target 0 corner 7 ring 2 at (1.50, 2.25): not projectable\n"
            "left out 2 corner observation(s): target 0 (" + TargetName(board) + ") 2 in 2 photo(s)\n");
}

TEST(CalibrationChecks, DatasetAndSolvedAgain) {
  TargetSpec board;
  board.type = TargetType::kChessboard;
  board.rows = 6;
  board.cols = 8;
  Observations detections;
  detections.images.resize(3);
  CalibrationInfo info;
  info.images = 3;
  info.targets = TargetsDescription({board});
  EXPECT_EQ(DatasetMismatch(info, detections, {board}), "");
  info.images = 4;
  EXPECT_EQ(DatasetMismatch(info, detections, {board}),
            "its calibration: dataset: has 4 images of " + info.targets + "; these have 3 images of " +
                info.targets);

  info.parameters = {"fx", "cx"};
  info.values = {1000, 640};
  info.sigma = {2, 0.5};
  CalibrationResult result;
  result.estimate.names = {"cx", "fx"};
  result.estimate.values = Eigen::Vector2d(640.4, 1001.9);  // 0.8 and 0.95 sigma: stayed
  EXPECT_EQ(MovedWhenSolvedAgain(info, result), "");
  result.estimate.values(0) = 641.0;  // 2 sigma
  EXPECT_EQ(MovedWhenSolvedAgain(info, result), "cx moved 2.0 sigma when solved again");
}

TEST(MonteCarlo, NoisyAddsWhiteNoiseOfEachGroupsSigma) {
  ExactSession exact;
  exact.detections.images.resize(1);
  auto& image = exact.detections.images[0];
  for (int k = 0; k < 4000; ++k) {
    image.corners.push_back(Corner(0, k, k % 2 ? Mirror::kTwo : Mirror::kOne, 5, 5));
  }
  LipEdgeObservation edge;
  edge.points.assign(2000, Eigen::Vector2d(1, 1));
  image.lips = {edge};
  const double sigma[2] = {0.5, 0.25};
  const Observations noisy = Noisy(exact, sigma, 0.1, 7);
  double sum2[2] = {0, 0};
  for (const auto& c : noisy.images[0].corners) {
    sum2[MirrorIndex(c.mirror) - 1] += (c.pixel - Eigen::Vector2d(5, 5)).squaredNorm();
  }
  // 2000 corners per ring, two axes each: the sample sigma within ~2% (3.5 standard errors).
  EXPECT_NEAR(std::sqrt(sum2[0] / 4000), 0.5, 0.5 * 0.04);
  EXPECT_NEAR(std::sqrt(sum2[1] / 4000), 0.25, 0.25 * 0.04);
  double lip2 = 0;
  for (const auto& p : noisy.images[0].lips[0].points) lip2 += (p - Eigen::Vector2d(1, 1)).squaredNorm();
  EXPECT_NEAR(std::sqrt(lip2 / 4000), 0.1, 0.1 * 0.04);
  // The same seed, the same session; another seed, another.
  EXPECT_EQ(Noisy(exact, sigma, 0.1, 7).images[0].corners[3].pixel,
            noisy.images[0].corners[3].pixel);
  EXPECT_NE(Noisy(exact, sigma, 0.1, 8).images[0].corners[3].pixel,
            noisy.images[0].corners[3].pixel);
}

// The corner noise check's text: each ring with corners, their ratio, the unmatched.
TEST(CalibrationChecks, CornerNoiseText) {
  CalibrationResult result;
  result.residuals.per_mirror_rms_px[0] = 0.2;
  result.residuals.per_mirror_rms_px[1] = 0.3;
  CornerNoise noise;
  noise.true_rms_px[0] = 0.25;
  noise.count[0] = 12;
  noise.unmatched = 2;
  EXPECT_EQ(CornerNoiseText(result, noise, "t.yaml"),
            "corner noise (--truth t.yaml): reprojection RMS against the detector's true error "
            "over the same corners (2-D RMS)\n"
            "  ring 1: 0.2000 px vs 0.2500 px over 12 corners: ratio 0.80\n"
            "  (2 detected corners have no true counterpart)\n");
}

// "name value sigma" with 17 digits: values read back bit for bit.
TEST(CalibrationChecks, ValuesTextReadsBackExactly) {
  CalibrationResult result;
  result.estimate.names = {"fx", "mirror1.rx"};
  result.estimate.values = Eigen::Vector2d(1450.1 + 1e-9, 0.1 + 0.2);
  result.uncertainty.sigma = Eigen::Vector2d(0.5, 1e-5);
  std::istringstream in(ValuesText(result));
  std::string name;
  double value = 0, sigma = 0;
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(in >> name >> value >> sigma);
    EXPECT_EQ(name, result.estimate.names[i]);
    EXPECT_EQ(value, result.estimate.values(i));
    EXPECT_EQ(sigma, result.uncertainty.sigma(i));
  }
}

// R0's measured noise: the corners' groups by name, the lips' RMS only with lips.
TEST(MonteCarlo, MeasuredNoiseOfTheReference) {
  CalibrationResult r0;
  r0.residuals.lip_rms_px = 0.07;
  VarianceComponent ring1, ring2, lips;
  ring1.group = "corners ring 1";
  ring1.sigma_px = 0.1;
  ring2.group = "corners ring 2";
  ring2.sigma_px = 0.2;
  lips.group = "lips";
  lips.sigma_px = 0.3;
  r0.uncertainty.variance_components = {lips, ring2, ring1};
  const MeasuredNoise with_lips = MeasuredNoiseOf(r0, true);
  EXPECT_EQ(with_lips.corner_sigma_px[0], 0.1);
  EXPECT_EQ(with_lips.corner_sigma_px[1], 0.2);
  EXPECT_EQ(with_lips.lip_sigma_px, 0.07);
  EXPECT_EQ(MeasuredNoiseOf(r0, false).lip_sigma_px, 0.0);
}

}  // namespace
}  // namespace omni::calib
