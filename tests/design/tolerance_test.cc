// Tolerance checks and their image effect (design/tolerance.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "design/tolerance.h"
#include "io/model_file.h"

namespace omni::design {
namespace {

RigParams BigRig() {
  return io::ReadModelFile(std::string(OMNI_SAMPLE_DIR) + "/big_rig_ideal.yaml");
}

// A calibrated-looking model: mirror 1 decentred by (0.12, -0.05) mm with a correlated
// covariance of (tx, ty).
RigParams WithCovariance(double tx, double ty, double sxx, double syy, double sxy) {
  RigParams rig = BigRig();
  rig.kind = ModelKind::kNoncentral;
  rig.mirror1_pose[kTx] = tx;
  rig.mirror1_pose[kTy] = ty;
  CalibrationInfo c;
  c.parameters = {"mirror1.tx", "mirror1.ty"};
  c.values = {tx, ty};
  c.sigma = {std::sqrt(sxx), std::sqrt(syy)};
  c.covariance = {sxx, sxy, sxy, syy};
  rig.calibration = c;
  return rig;
}

// Oracle for the first-order sigma of |(tx, ty)|: the spread of the magnitude over samples of
// (tx, ty) drawn from the covariance (far from the origin, where first order holds).
TEST(ToleranceTest, DecentreSigmaMatchesMonteCarlo) {
  const double tx = 0.25, ty = -0.10, sxx = 4e-4, syy = 9e-4, sxy = -2e-4;
  ToleranceSpec spec;
  spec.mirror[0].decentre_mm = 0.3;
  const auto checks = CheckTolerances(WithCovariance(tx, ty, sxx, syy, sxy), spec);
  ASSERT_EQ(checks.size(), 1u);
  ASSERT_TRUE(checks[0].sigma.has_value());
  EXPECT_NEAR(checks[0].value, std::hypot(tx, ty), 1e-15);

  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  const double l11 = std::sqrt(sxx), l21 = sxy / l11, l22 = std::sqrt(syy - l21 * l21);
  double sum = 0, sum2 = 0;
  const int kSamples = 200000;
  for (int i = 0; i < kSamples; ++i) {
    const double a = n(rng), b = n(rng);
    const double r = std::hypot(tx + l11 * a, ty + l21 * a + l22 * b);
    sum += r;
    sum2 += r * r;
  }
  const double mean = sum / kSamples, sd = std::sqrt(sum2 / kSamples - mean * mean);
  EXPECT_NEAR(*checks[0].sigma, sd, 0.03 * sd);
}

TEST(ToleranceTest, VerdictsRespectTheUncertainty) {
  ToleranceSpec spec;
  spec.mirror[0].decentre_mm = 0.3;
  // 0.2 +- 0.02: pass; 0.5 +- 0.02: fail; 0.29 +- 0.02: undecided at 2 sigma.
  EXPECT_EQ(CheckTolerances(WithCovariance(0.2, 0, 4e-4, 4e-4, 0), spec)[0].verdict, Verdict::kPass);
  EXPECT_EQ(CheckTolerances(WithCovariance(0.5, 0, 4e-4, 4e-4, 0), spec)[0].verdict, Verdict::kFail);
  EXPECT_EQ(CheckTolerances(WithCovariance(0.29, 0, 4e-4, 4e-4, 0), spec)[0].verdict,
            Verdict::kUndecided);
  // Without a covariance the value alone decides, and no sigma is claimed.
  RigParams bare = WithCovariance(0.29, 0, 4e-4, 4e-4, 0);
  bare.calibration.reset();
  const auto checks = CheckTolerances(bare, spec);
  EXPECT_FALSE(checks[0].sigma.has_value());
  EXPECT_EQ(checks[0].verdict, Verdict::kPass);
}

TEST(ToleranceTest, ImageEffectIsZeroForZeroToleranceAndGrowsWithIt) {
  const RigParams rig = BigRig();
  ToleranceSpec none;
  for (auto& body : none.mirror) body = {0, 0, 0};
  none.reflex_tilt_rad = 0;
  none.reflex_dz_mm = 0;
  const ImageEffect zero = SimulateImageEffect(rig, none, 3, 1000, 1);
  ASSERT_GT(zero.points, 100);
  EXPECT_LT(zero.max_px[0], 1e-9);
  EXPECT_LT(zero.max_px[1], 1e-9);

  ToleranceSpec small = none, large = none;
  small.mirror[1].tilt_rad = 0.1 * M_PI / 180;
  large.mirror[1].tilt_rad = 0.4 * M_PI / 180;
  const ImageEffect a = SimulateImageEffect(rig, small, 30, 1000, 2);
  const ImageEffect b = SimulateImageEffect(rig, large, 30, 1000, 2);
  // Mirror 2 alone does not move ring 1; its tilt moves ring 2, about linearly for small tilts.
  EXPECT_LT(a.max_px[0], 1e-9);
  EXPECT_GT(a.p95_px[1], 0.1);
  EXPECT_NEAR(b.p95_px[1] / a.p95_px[1], 4.0, 0.6);
}

// Machined mirrors (issue 40). P1(w) = w runs from -1 at r_min to +1 at r_max: a profile of
// sag_p1 alone has a peak-to-valley of exactly 2 |sag_p1|, and its sigma 2 sigma(sag_p1).
TEST(ToleranceTest, ProfilePeakToValleyWithItsSigma) {
  RigParams rig = BigRig();
  rig.kind = ModelKind::kNoncentral;
  rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
  rig.mirror1_profile = {-0.004, 0, 0, 0, 0, 0};
  CalibrationInfo c;
  c.parameters = {"mirror1.sag_p1"};
  c.values = {-0.004};
  c.sigma = {0.001};
  c.covariance = {1e-6};
  rig.calibration = c;
  ToleranceSpec spec;
  spec.mirror[0].profile_pv_mm = 0.02;
  spec.mirror[1].profile_pv_mm = 0.02;
  auto checks = CheckTolerances(rig, spec);
  ASSERT_EQ(checks.size(), 2u);
  EXPECT_EQ(checks[0].name, "mirror1.profile");
  EXPECT_NEAR(checks[0].value, 0.008, 1e-9);
  ASSERT_TRUE(checks[0].sigma.has_value());
  EXPECT_NEAR(*checks[0].sigma, 0.002, 1e-9);
  EXPECT_EQ(checks[0].verdict, Verdict::kPass);  // 0.008 + 2 x 0.002 <= 0.02
  // Mirror 2 has no profile in the model: never measured, no verdict.
  EXPECT_EQ(checks[1].name, "mirror2.profile");
  EXPECT_EQ(checks[1].verdict, Verdict::kUndecided);
  spec.mirror[0].profile_pv_mm = 0.003;
  EXPECT_EQ(CheckTolerances(rig, spec)[0].verdict, Verdict::kFail);  // 0.008 - 0.004 > 0.003
  spec.mirror[0].profile_pv_mm = 0.01;
  EXPECT_EQ(CheckTolerances(rig, spec)[0].verdict, Verdict::kUndecided);
}

// Random profiles have the peak-to-valley asked for (measured on a finer grid than they were
// scaled on), and their effect on the images grows linearly with it at these microns.
TEST(ToleranceTest, ProfileSensitivityIsLinearInThePeakToValley) {
  const RigParams rig = BigRig();
  const ProfileShape shape = DefaultProfileShape(rig, Mirror::kOne);
  std::mt19937 rng(5);
  for (int i = 0; i < 5; ++i) {
    const auto c = RandomProfile(shape, 0.01, &rng);
    double lo = 1, hi = -1;
    for (int k = 0; k <= 400; ++k) {
      const double r = shape.r_min + (shape.r_max - shape.r_min) * k / 400;
      for (int deg = 0; deg < 360; ++deg) {
        const double z = ProfileSag(c.data(), shape, r * std::cos(deg * M_PI / 180),
                                    r * std::sin(deg * M_PI / 180), false).z;
        lo = std::min(lo, z);
        hi = std::max(hi, z);
      }
    }
    EXPECT_NEAR(hi - lo, 0.01, 0.0003);
  }
  const ProfileSensitivity a = SimulateProfileSensitivity(rig, 0.005, 10, 3);
  const ProfileSensitivity b = SimulateProfileSensitivity(rig, 0.010, 10, 3);
  std::printf("10 um PV: p95 shift at 1 m %.3f / %.3f px, range error at 2 m %.3f%%; for 0.1 px "
              "%.2f um, for 1%% at 2 m %.1f um\n",
              b.p95_shift_px_1m[0], b.p95_shift_px_1m[1], 100 * b.p95_range_error_2m,
              1000 * b.PvFor(0.1, b.p95_shift_px_1m[0]), 1000 * b.PvFor(0.01, b.p95_range_error_2m));
  for (int m = 0; m < 2; ++m) {
    EXPECT_GT(a.p95_shift_px_1m[m], 0.05);
    EXPECT_NEAR(b.p95_shift_px_1m[m] / a.p95_shift_px_1m[m], 2.0, 0.1);
  }
  EXPECT_NEAR(b.p95_range_error_2m / a.p95_range_error_2m, 2.0, 0.2);
}

// A FAIL says which way to move the part and by how much; a parameter correlated beyond 0.99
// with cx or cy is said to lie in the camera-rotation valley; a PASS says neither.
TEST(ToleranceTest, FailSaysWhichWayAndTheValleyIsNamed) {
  ToleranceCheck decentre;
  decentre.name = "mirror2.decentre";
  decentre.unit = "mm";
  decentre.value = 0.5;
  decentre.sigma = 0.01;
  decentre.limit = 0.3;
  decentre.verdict = Verdict::kFail;
  decentre.parameters = {"mirror2.tx", "mirror2.ty"};
  decentre.components = {0.3, -0.4};
  EXPECT_EQ(Correction(decentre),
            "(mirror2.tx, mirror2.ty) is (+0.300, -0.400) mm, |.| 0.500 beyond 0.300 by 0.200: "
            "move mirror2 by (-0.120, +0.160) mm in C's x, y (x image right, y image down), "
            "towards the axis");
  ToleranceCheck axial;
  axial.name = "mirror1.axial";
  axial.unit = "mm";
  axial.value = 0.41;
  axial.sigma = 0.02;
  axial.limit = 0.2;
  axial.verdict = Verdict::kFail;
  axial.parameters = {"mirror1.tz"};
  axial.components = {0.41};
  EXPECT_EQ(Correction(axial), "mirror1.tz is +0.410 mm, 0.210 mm beyond +-0.200: move mirror1 "
                               "0.210 mm along -z (towards the camera)");
  EXPECT_EQ(RotationValleyNote(axial), "");
  axial.verdict = Verdict::kPass;
  EXPECT_EQ(Correction(axial), "");
  // The calibrated test model: mirror 1's tilt is in the valley (rx ~ cy +0.9997).
  const RigParams rig = io::ReadModelFile(std::string(OMNI_SAMPLE_DIR) + "/../tests/data/calibrated_big_rig.yaml");
  ToleranceSpec spec;
  spec.mirror[0].tilt_rad = 0.01 * M_PI / 180;
  spec.mirror[0].axial_mm = 5;
  const std::vector<ToleranceCheck> checks = CheckTolerances(rig, spec);
  ASSERT_EQ(checks.size(), 2u);
  EXPECT_EQ(checks[0].valley_pair, "mirror1.rx ~ cy");
  EXPECT_GT(checks[0].valley_correlation, 0.999);
  EXPECT_NE(RotationValleyNote(checks[0]).find("camera-rotation valley"), std::string::npos);
  // In the valley no move is advised: turning mirror 1 cannot be told from turning the camera.
  EXPECT_EQ(Correction(checks[0]), "");
  EXPECT_LT(std::abs(checks[1].valley_correlation), 0.99);  // tz
  EXPECT_EQ(RotationValleyNote(checks[1]), "");
}

}  // namespace
}  // namespace omni::design
