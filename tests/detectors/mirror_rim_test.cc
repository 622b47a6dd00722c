// The mirror rim finder (detectors/lips/mirror_rim.h) on drawn photos of a single-mirror camera
// whose rim is known exactly: a textured mirror image inside a circle, the dark housing outside,
// the camera's own dark reflection at the centre, a sleeve across part of the rim; area-sampled
// (4x4 per pixel), blurred, noisy and JPEG-compressed. The circle found against the drawn one.
#include "detectors/lips/mirror_rim.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace omni::detectors {
namespace {

struct Drawn {
  double cx = 402.3, cy = 297.8, r = 231.6;
};

// Grey level of the scene at (x, y): the mirror's texture inside the rim (seeded blobs and
// stripes), the camera's reflection, the sleeve (a dark band crossing the rim's lower left),
// the housing outside.
double Scene(const Drawn& d, double x, double y, int seed) {
  const double dx = x - d.cx, dy = y - d.cy, rho = std::hypot(dx, dy);
  const double azimuth = std::atan2(dy, dx);
  if (rho > d.r) return rho > d.r * 1.25 ? 45 : 20;  // housing, then the outer plate
  if (rho < 0.12 * d.r) return 6;                    // the camera's reflection
  if (azimuth > 1.9 && azimuth < 2.6 && rho > 0.5 * d.r) return 24;  // a dark sleeve
  const double s = seed * 0.7;
  double v = 140 + 45 * std::sin(0.05 * x + s) * std::cos(0.043 * y - s) +
             35 * std::sin(0.011 * (x + 2 * y) + 2 * s);
  if (std::fmod(std::abs(x * 0.02 + y * 0.013 + s), 1.0) < 0.3) v -= 50;  // stripes
  return std::clamp(v, 40.0, 235.0);
}

cv::Mat Photo(const Drawn& d, int seed) {
  cv::Mat img(600, 800, CV_32F);
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      double sum = 0;
      for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) sum += Scene(d, x - 0.375 + 0.25 * i, y - 0.375 + 0.25 * j, seed);
      }
      img.at<float>(y, x) = static_cast<float>(sum / 16);
    }
  }
  cv::GaussianBlur(img, img, cv::Size(), 1.2);
  cv::Mat noise(img.size(), CV_32F);
  cv::randn(noise, 0, 2.0);
  cv::theRNG().state = seed;
  img += noise;
  cv::Mat grey;
  img.convertTo(grey, CV_8U);
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", grey, jpeg, {cv::IMWRITE_JPEG_QUALITY, 85});
  return cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
}

TEST(MirrorRim, FindsTheDrawnRimInOnePhotoAndInSeveral) {
  const Drawn d;
  const MirrorRim one = FindMirrorRim({Photo(d, 1)});
  ASSERT_TRUE(one.found) << one.why;
  EXPECT_NEAR(one.centre.x(), d.cx, 0.1);
  EXPECT_NEAR(one.centre.y(), d.cy, 0.1);
  EXPECT_NEAR(one.radius_px, d.r, 0.1);
  EXPECT_GT(one.coverage, 0.75);  // the sleeve hides ~10% of the rim
  EXPECT_LT(one.coverage, 0.95);
  const MirrorRim several = FindMirrorRim({Photo(d, 2), Photo(d, 3), Photo(d, 4)});
  ASSERT_TRUE(several.found) << several.why;
  EXPECT_NEAR(several.centre.x(), d.cx, 0.1);
  EXPECT_NEAR(several.centre.y(), d.cy, 0.1);
  EXPECT_NEAR(several.radius_px, d.r, 0.1);
}

TEST(MirrorRim, ADarkerMirrorIsFoundWithItsPolarity) {
  const Drawn d;
  cv::Mat inverted = 255 - Photo(d, 5);
  MirrorRimOptions options;
  options.inside_brighter = false;
  const MirrorRim rim = FindMirrorRim({inverted}, options);
  ASSERT_TRUE(rim.found) << rim.why;
  EXPECT_NEAR(rim.radius_px, d.r, 0.1);
}

TEST(MirrorRim, NoRimNoCircleAndBadOptionsNamed) {
  cv::Mat noise(480, 640, CV_8U);
  cv::randu(noise, 0, 255);
  const MirrorRim rim = FindMirrorRim({noise});
  EXPECT_FALSE(rim.found);
  EXPECT_FALSE(rim.why.empty());
  MirrorRimOptions options;
  options.rays = 10;
  EXPECT_EQ(options.Check(), "rays: expected at least 36");
  EXPECT_THROW(FindMirrorRim({noise}, options), std::invalid_argument);
  EXPECT_THROW(FindMirrorRim({noise, cv::Mat(10, 10, CV_8U)}), std::invalid_argument);
}

}  // namespace
}  // namespace omni::detectors
