// Fitting a measured profile scan (model/profile_fit.h): scans generated from known terms through
// ProfileSag, with noise; the fitted terms against the truth, the predicted covariance against
// the spread of many noisy fits (Monte Carlo), and what a single scan line cannot tell.
#include "model/profile_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace omni {
namespace {

ProfileShape Shape() {
  ProfileShape shape;
  shape.present = true;
  shape.r_min = 17;
  shape.r_max = 37;
  return shape;
}

constexpr std::array<double, kProfileTerms> kTruth = {0.004, -0.0015, 0.0008, -0.0003, 0.0006,
                                                      -0.0004};

// Scan lines at `azimuths_deg`, radii 10..40 mm every 0.5 mm, the surface's sag plus a piston,
// plus Gaussian noise of `sigma` mm.
std::vector<ProfileScanPoint> Scan(const ProfileShape& shape, std::vector<double> azimuths_deg,
                                   double sigma, std::mt19937* rng) {
  std::normal_distribution<double> noise(0, sigma);
  std::vector<ProfileScanPoint> scan;
  for (double deg : azimuths_deg) {
    for (double r = 10; r <= 40; r += 0.5) {
      const double t = deg * M_PI / 180;
      const double sag =
          ProfileSag(kTruth.data(), shape, r * std::cos(t), r * std::sin(t), false).z + 0.02;
      scan.push_back({r, sag + noise(*rng), t});
    }
  }
  return scan;
}

TEST(ProfileFit, RecoversTheTermsAndThePistonFromFourAzimuths) {
  std::mt19937 rng(5);
  const ProfileShape shape = Shape();
  const ProfileFit fit = FitProfileToScan(Scan(shape, {0, 45, 90, 135}, 0, &rng), shape, 1e-3);
  for (int i = 0; i < kProfileTerms; ++i) {
    EXPECT_TRUE(fit.measured[i]);
    EXPECT_NEAR(fit.coeffs[i], kTruth[i], 1e-12) << i;
  }
  EXPECT_NEAR(fit.piston_mm, 0.02, 1e-12);
  EXPECT_EQ(fit.points, 4 * 41);  // 17..37 mm every 0.5 mm
  EXPECT_EQ(fit.skipped, 4 * 20);
  EXPECT_LT(fit.residual_rms_mm, 1e-12);
}

TEST(ProfileFit, PredictedSigmasMatchTheSpreadOfNoisyFits) {
  std::mt19937 rng(7);
  const ProfileShape shape = Shape();
  const double sigma = 1e-3;  // 1 um per point
  const int runs = 400;
  std::array<double, kProfileTerms> sum{}, sum2{};
  ProfileFit fit;
  for (int run = 0; run < runs; ++run) {
    fit = FitProfileToScan(Scan(shape, {0, 60, 120}, sigma, &rng), shape, sigma);
    for (int i = 0; i < kProfileTerms; ++i) {
      const double e = fit.coeffs[i] - kTruth[i];
      sum[i] += e;
      sum2[i] += e * e;
    }
  }
  const auto predicted = fit.Sigma();
  for (int i = 0; i < kProfileTerms; ++i) {
    const double spread = std::sqrt(sum2[i] / runs - (sum[i] / runs) * (sum[i] / runs));
    // 400 runs: the sample sigma is within ~3.5% (1 sigma) of the truth.
    EXPECT_NEAR(spread / predicted[i], 1.0, 0.15) << i;
    EXPECT_LT(std::abs(sum[i] / runs), 4 * predicted[i] / std::sqrt(runs)) << i;  // unbiased
  }
  EXPECT_NEAR(fit.residual_rms_mm, sigma, 0.15 * sigma);
}

TEST(ProfileFit, OneScanLineLeavesTheAstigmatismUnmeasured) {
  std::mt19937 rng(9);
  ProfileShape shape = Shape();
  std::array<double, kProfileTerms> symmetric = kTruth;
  symmetric[4] = symmetric[5] = 0;
  std::vector<ProfileScanPoint> scan;
  for (double r = 17; r <= 37; r += 0.25) {
    scan.push_back({r, ProfileSag(symmetric.data(), shape, r, 0.0, false).z, 0});
  }
  const ProfileFit fit = FitProfileToScan(scan, shape, 1e-3);
  EXPECT_FALSE(fit.measured[4]);
  EXPECT_FALSE(fit.measured[5]);
  EXPECT_EQ(fit.Sigma()[4], 0);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(fit.coeffs[i], symmetric[i], 1e-12);
  // Two lines 180 deg apart are one line for cos 2theta and sin 2theta too.
  for (auto& p : scan) p.theta_rad = M_PI;
  std::vector<ProfileScanPoint> both = scan;
  for (auto p : scan) {
    p.theta_rad = 0;
    both.push_back(p);
  }
  EXPECT_FALSE(FitProfileToScan(both, shape, 1e-3).measured[4]);
  // Two lines 45 deg apart leave one combination of the r^2 terms (P1, cos2, sin2) open: the
  // astigmatism needs a third azimuth.
  for (auto& p : both) p.theta_rad = p.theta_rad == 0 ? 0 : M_PI / 4;
  EXPECT_FALSE(FitProfileToScan(both, shape, 1e-3).measured[4]);
  for (auto p : scan) {
    p.theta_rad = M_PI / 2;
    both.push_back(p);
  }
  const ProfileFit three = FitProfileToScan(both, shape, 1e-3);
  EXPECT_TRUE(three.measured[4] && three.measured[5]);
  for (int i = 0; i < kProfileTerms; ++i) EXPECT_NEAR(three.coeffs[i], symmetric[i], 1e-12);
}

TEST(ProfileFit, MachiningRippleShowsInTheResidualPeakToValley) {
  std::mt19937 rng(11);
  ProfileShape shape = Shape();
  shape.ripple_amplitude = 0.0005;  // 0.5 um, 1.7 mm period: no term can follow it
  shape.ripple_period = 1.7;  // the 0.5 mm samples step 5/17 of a period: they reach its peaks
  const std::vector<ProfileScanPoint> scan = Scan(shape, {0, 45, 90, 135}, 0, &rng);
  const ProfileFit fit = FitProfileToScan(scan, shape, 1e-4);
  EXPECT_NEAR(fit.residual_pv_mm, 2 * shape.ripple_amplitude, 0.2 * shape.ripple_amplitude);
  // The ripple leaks into the terms by a fraction of its amplitude only.
  for (int i = 0; i < kProfileTerms; ++i) {
    EXPECT_NEAR(fit.coeffs[i], kTruth[i], 0.25 * shape.ripple_amplitude) << i;
  }
}

TEST(ProfileFit, TooFewPointsInsideTheRadiiIsRefused) {
  const std::vector<ProfileScanPoint> scan = {{20, 0, 0}, {25, 0, 0}, {30, 0, 0}};
  EXPECT_THROW(FitProfileToScan(scan, Shape(), 1e-3), std::invalid_argument);
}

}  // namespace
}  // namespace omni
