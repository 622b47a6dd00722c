// Edge placement on a JPEG's luma (detectors/lips/luma_edge.h): the noise expectations against Monte
// Carlo, and a dark band's blurred edge through a camera's noise and sRGB encoding (the band's
// true radius known exactly) placed without the bias the noise gives a noise-free Y' curve.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/lips/luma_edge.h"
#include "io/image_file.h"

namespace omni::detectors {
namespace {

double Srgb(double linear_level) {
  return 255.0 * io::SrgbFromLinear(std::clamp(linear_level, 0.0, 255.0) / 255.0);
}

TEST(NoisyLevels, ExpectationsAgreeWithMonteCarlo) {
  const double sigma2 = 1.5;
  const NoisyLevels noise(sigma2);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, std::sqrt(sigma2));
  constexpr int kSamples = 400000;
  for (double x : {-1.0, 0.0, 1.0, 3.0, 8.0, 30.0, 100.0}) {
    double linear = 0, encoded = 0;
    for (int i = 0; i < kSamples; ++i) {
      const double v = std::clamp(x + n(rng), 0.0, 255.0);
      linear += v;
      encoded += Srgb(v);
    }
    linear /= kSamples;
    encoded /= kSamples;
    // Monte Carlo's standard error: <= 0.002 levels linear, <= 0.02 encoded (dark levels).
    EXPECT_NEAR(noise.Linear(x), linear, 0.01) << "x " << x;
    EXPECT_NEAR(noise.Encoded(x), encoded, 0.06) << "x " << x;
    // The noise lowers a mid level's mean encoding (sRGB is concave) and raises black's (clip).
    if (x >= 8) {
      EXPECT_LT(noise.Encoded(x), Srgb(x)) << "x " << x;
    }
    if (x <= 0) {
      EXPECT_GT(noise.Encoded(x), Srgb(x)) << "x " << x;
    }
  }
  for (double x : {-1.0, 0.5, 3.0, 30.0}) EXPECT_NEAR(noise.NoiseFree(noise.Linear(x)), x, 0.01);
  const NoisyLevels none(0);
  EXPECT_DOUBLE_EQ(none.Encoded(7.0), Srgb(7.0));
  EXPECT_DOUBLE_EQ(none.NoiseFree(7.0), 7.0);
}

// A navy band (linear BGR 24, 6, 4 of 255: the painted rig's under room light) outward of a
// circle of radius kRadius against black, blurred (Gaussian, sigma 0.8 px), with Gaussian sensor
// noise of variance 1 level^2 before the camera's clip and sRGB encoding to 8 bit; the file's Y'
// as a JPEG computes it from those values, the decoded colours back in linear light (16 bit).
struct DarkBandImage {
  static constexpr double kRadius = 380.0;
  const Eigen::Vector2d centre{-300.0, 150.0};
  cv::Mat linear, luma;
  DarkBandImage() {
    const Eigen::Vector3d band(24, 6, 4);
    cv::Mat encoded(300, 120, CV_8UC3);
    luma.create(300, 120, CV_8U);
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0.0, 1.0);
    for (int v = 0; v < encoded.rows; ++v) {
      for (int u = 0; u < encoded.cols; ++u) {
        const double r = (Eigen::Vector2d(u, v) - centre).norm();
        const double alpha = 0.5 * std::erfc(-(r - kRadius) / (0.8 * std::sqrt(2.0)));
        double y = 0;
        cv::Vec3b& out = encoded.at<cv::Vec3b>(v, u);
        for (int c = 0; c < 3; ++c) {
          out[c] = cv::saturate_cast<uchar>(std::round(Srgb(alpha * band[c] + noise(rng))));
          y += Eigen::Vector3d(0.114, 0.587, 0.299)[c] * out[c];
        }
        luma.at<uchar>(v, u) = cv::saturate_cast<uchar>(std::round(y));
      }
    }
    linear = io::LinearImage(encoded, io::ToneCurve::kSrgb);
  }
};

TEST(LumaEdge, DarkBandEdgePlacedWithoutTheNoiseBias) {
  const DarkBandImage image;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> start(-0.5, 0.5);
  // Points along the arc, each starting up to 0.5 px off (as the colour crossing leaves them).
  std::vector<LumaProfile> profiles;
  std::vector<double> rho;
  std::vector<std::pair<Eigen::Vector3d, double>> band_sides;
  for (double v = 20; v <= 280; v += 4) {
    const double dv = v - image.centre.y();
    const double u = image.centre.x() + std::sqrt(DarkBandImage::kRadius * DarkBandImage::kRadius -
                                                  dv * dv);
    const Eigen::Vector2d outward = (Eigen::Vector2d(u, v) - image.centre).normalized();
    rho.push_back(DarkBandImage::kRadius + start(rng));
    profiles.push_back(GatherLumaProfile(image.linear, image.luma, image.centre, outward,
                                         rho.back(), +1, 6));
    // The noise from the band's side 2.5-3.5 px in, as the lip detector takes it.
    const LumaProfile inside = GatherLumaProfile(image.linear, image.luma, image.centre, outward,
                                                 rho.back(), +1, 6, 2.5, 3.5);
    band_sides.emplace_back(inside.side_colour[1], inside.side_luma[1]);
  }
  const double sigma2 = EstimateEncodingNoise(band_sides);
  std::printf("noise variance estimated %.3f levels^2 (true 1)\n", sigma2);
  EXPECT_GT(sigma2, 0.6);
  EXPECT_LT(sigma2, 1.5);
  auto signed_mean = [&](const NoisyLevels& noise, double* rms) {
    double sum = 0, sum2 = 0;
    int n = 0;
    for (size_t i = 0; i < profiles.size(); ++i) {
      const std::optional<double> offset = LumaEdgeOffset(profiles[i], noise, 4);
      if (!offset) continue;
      const double error = rho[i] + *offset - DarkBandImage::kRadius;
      sum += error;
      sum2 += error * error;
      ++n;
    }
    EXPECT_GE(n, static_cast<int>(profiles.size()) - 2);
    *rms = std::sqrt(sum2 / std::max(1, n));
    return sum / std::max(1, n);
  };
  double rms_modelled = 0, rms_noise_free = 0;
  const double modelled = signed_mean(NoisyLevels(sigma2), &rms_modelled);
  const double noise_free = signed_mean(NoisyLevels(0), &rms_noise_free);
  std::printf("mean signed error: noise modelled %+.3f px (rms %.3f), noise-free curve %+.3f px "
              "(rms %.3f), %zu points\n", modelled, rms_modelled, noise_free, rms_noise_free,
              profiles.size());
  // 66 points of rms ~0.08 px: the mean is known to +-0.01 px.
  EXPECT_LT(std::abs(modelled), 0.03);
  EXPECT_LT(rms_modelled, 0.12);
  // The noise-free curve misplaces the dark band's edge (the test can tell the two apart).
  EXPECT_GT(std::abs(noise_free), std::abs(modelled) + 0.03);
}

// A band (linear BGR `band`) outward of a circle against `outside`, blurred by a Gaussian of
// sigma `sigma` px, no noise, 8-bit sRGB, Y' from those values: the mean signed error (px, + into
// the band) of the luma placement from starts up to 0.5 px off, over the points placed.
double DrawnEdgeError(double sigma, const Eigen::Vector3d& band, const Eigen::Vector3d& outside,
                      int* placed = nullptr) {
  constexpr double kRadius = 380.0;
  const Eigen::Vector2d centre(-300.0, 150.0);
  cv::Mat encoded(300, 120, CV_8UC3), luma(300, 120, CV_8U);
  for (int v = 0; v < encoded.rows; ++v) {
    for (int u = 0; u < encoded.cols; ++u) {
      const double r = (Eigen::Vector2d(u, v) - centre).norm();
      const double alpha = 0.5 * std::erfc(-(r - kRadius) / (sigma * std::sqrt(2.0)));
      double y = 0;
      cv::Vec3b& out = encoded.at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) {
        out[c] = cv::saturate_cast<uchar>(
            std::round(Srgb(outside[c] + alpha * (band[c] - outside[c]))));
        y += Eigen::Vector3d(0.114, 0.587, 0.299)[c] * out[c];
      }
      luma.at<uchar>(v, u) = cv::saturate_cast<uchar>(std::round(y));
    }
  }
  const cv::Mat linear = io::LinearImage(encoded, io::ToneCurve::kSrgb);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> start(-0.5, 0.5);
  double sum = 0;
  int n = 0;
  for (double v = 20; v <= 280; v += 1.7) {
    const double dv = v - centre.y();
    const double u = centre.x() + std::sqrt(kRadius * kRadius - dv * dv);
    const Eigen::Vector2d outward = (Eigen::Vector2d(u, v) - centre).normalized();
    const double rho = kRadius + start(rng);
    const std::optional<double> offset = LumaEdgeOffset(
        GatherLumaProfile(linear, luma, centre, outward, rho, +1, 6), NoisyLevels(0), 4);
    if (!offset) continue;
    sum += rho + *offset - kRadius;
    ++n;
  }
  if (placed) *placed = n;
  return sum / std::max(1, n);
}

// The luma placement's own constant offset on drawn edges under the cameras' blurs (sigma 0.4-1.8
// px: the realistic preset's 0.6 / 0.9, the webcam's 1.8): the blue lip (linear BGR 204, 0, 0,
// as POV-Ray renders the prototype's) against the grey (32) beyond its outer edge, or a lighter
// grey (100), and the red lip against the grey. Exact Y', no noise, no JPEG: what is left is the
// estimator's, a line alpha(d) fitted over +-1.25 px while the blurred step saturates there (small
// blur) or its sides are not yet flat 1.5-3 px out (large blur), weighted by Y''s asymmetric bends:
// up to 0.04 px either way, the sign with the blur (docs/experiments.md, 2026-11-30, where the
// lips' constant offsets are traced; a blurred-step model fitted instead was within 0.011 px on
// the blue-on-grey edges here but worse on the renders, whose sides are not flat). A bound, not
// a claim of accuracy: the calibration's floor lip_edge_offset_floor_px (0.05) covers it.
TEST(LumaEdge, DrawnEdgesConstantOffsetUnderTheCamerasBlurs) {
  struct Case {
    Eigen::Vector3d band, outside;
  };
  const Case cases[] = {{{204, 0, 0}, {32, 32, 32}}, {{204, 0, 0}, {100, 100, 100}},
                        {{10, 30, 204}, {32, 32, 32}}};
  double worst = 0;
  for (double sigma : {0.4, 0.6, 0.9, 1.8}) {
    for (const Case& c : cases) {
      int placed = 0;
      const double error = DrawnEdgeError(sigma, c.band, c.outside, &placed);
      std::printf("blur %.1f px, band BGR %g/%g/%g against %g: mean signed error %+.4f px (%d "
                  "of 153 placed)\n", sigma, c.band[0], c.band[1], c.band[2], c.outside[0], error,
                  placed);
      EXPECT_GE(placed, 150);
      worst = std::max(worst, std::abs(error));
    }
  }
  EXPECT_LT(worst, 0.05);
}

TEST(LumaEdge, NoContrastNoPlacement) {
  LumaProfile flat;
  flat.d = {-1, -0.5, 0, 0.5, 1, -1, -0.5, 0, 0.5, 1};
  flat.luma.assign(flat.d.size(), 40.0);
  for (int s = 0; s < 2; ++s) {
    flat.side_colour[s] = Eigen::Vector3d(10, 10, 10);
    flat.side_luma[s] = 40;
    flat.side_spread[s] = 1;
    flat.side_count[s] = 10;
  }
  EXPECT_FALSE(LumaEdgeOffset(flat, NoisyLevels(1), 4).has_value());
}

}  // namespace
}  // namespace omni::detectors
