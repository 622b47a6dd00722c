// Drawn photos of a single-mirror camera whose rim is known exactly (the rim finder's and the
// single-mirror start's tests): a textured mirror image inside a circle, the dark housing
// outside, the camera's own dark reflection at the centre, a sleeve across part of the rim;
// area-sampled (4x4 per pixel), blurred, noisy and JPEG-compressed.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace omni::detectors::testing {

struct Drawn {
  double cx = 402.3, cy = 297.8, r = 231.6;
  int width = 800, height = 600;
};

// Grey level of the scene at (x, y): the mirror's texture inside the rim (seeded blobs and
// stripes), the camera's reflection, the sleeve (a dark band crossing the rim's lower left),
// the housing outside.
inline double Scene(const Drawn& d, double x, double y, int seed) {
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

inline cv::Mat Photo(const Drawn& d, int seed) {
  cv::Mat img(d.height, d.width, CV_32F);
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

}  // namespace omni::detectors::testing
