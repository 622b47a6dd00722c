// Test scaffolding for the pattern fits (tag_pattern_fit_test, target_pattern_align_test): a view
// whose map to the raw image is a gentle quadratic bend about `centre` (a mirror's map is smooth
// on a target's scale), its exact inverse by Newton, and a raw image rendered through it by
// sampling the plane 8 x 8 times per raw pixel (the pixel's area integrated), then blurred and
// given noise.
#pragma once

#include <cmath>
#include <functional>
#include <random>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "detectors/common/views.h"

namespace omni::detectors::testing {

struct Bend {
  Eigen::Vector2d centre;
  double xx = 0, xy = 0, yy = 0;  // raw = view + (xx dx^2 - xy dx dy, yy dy^2 + xy dx dy)

  Eigen::Vector2d RawOf(const Eigen::Vector2d& view) const {
    const Eigen::Vector2d d = view - centre;
    return view + Eigen::Vector2d(xx * d.x() * d.x() - xy * d.x() * d.y(), yy * d.y() * d.y() + xy * d.x() * d.y());
  }
  Eigen::Vector2d ViewOf(const Eigen::Vector2d& raw) const {
    Eigen::Vector2d v = raw;
    for (int it = 0; it < 8; ++it) {  // Newton: converged to 1e-12 px in 4
      const Eigen::Vector2d d = v - centre;
      Eigen::Matrix2d j;
      j << 1 + 2 * xx * d.x() - xy * d.y(), -xy * d.x(), xy * d.y(), 1 + 2 * yy * d.y() + xy * d.x();
      v -= j.inverse() * (RawOf(v) - raw);
    }
    return v;
  }
  // A size x size view with this bend as its map.
  RingView MakeView(int size) const {
    RingView view;
    view.width = view.height = size;
    view.map_x.create(size, size, CV_32F);
    view.map_y.create(size, size, CV_32F);
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        const Eigen::Vector2d raw = RawOf(Eigen::Vector2d(x, y));
        view.map_x.at<float>(y, x) = static_cast<float>(raw.x());
        view.map_y.at<float>(y, x) = static_cast<float>(raw.y());
      }
    }
    return view;
  }
};

// A size x size CV_32F raw image: 0.1 + 0.8 x the mean over 8 x 8 samples per pixel of
// `value_at(plane point)` (0 black, 1 white), the plane point of a raw point through the bend and
// `plane_from_view`; blurred by sigma_px, Gaussian noise `noise` added (seed `seed`).
inline cv::Mat RenderRaw(const Bend& bend, const Eigen::Matrix3d& plane_from_view, int size,
                         const std::function<double(const Eigen::Vector2d&)>& value_at, double sigma_px,
                         double noise, unsigned seed) {
  cv::Mat sharp(size, size, CV_32F), out;
  constexpr int kSub = 8;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      double sum = 0;
      for (int j = 0; j < kSub; ++j) {
        for (int i = 0; i < kSub; ++i) {
          const Eigen::Vector2d raw(x - 0.5 + (i + 0.5) / kSub, y - 0.5 + (j + 0.5) / kSub);
          const Eigen::Vector3d q = plane_from_view * bend.ViewOf(raw).homogeneous();
          sum += value_at(q.head<2>() / q.z());
        }
      }
      sharp.at<float>(y, x) = static_cast<float>(0.1 + 0.8 * sum / (kSub * kSub));
    }
  }
  cv::GaussianBlur(sharp, out, cv::Size(0, 0), sigma_px);
  std::mt19937 rng(seed);
  std::normal_distribution<float> gauss(0.0f, static_cast<float>(noise));
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) out.at<float>(y, x) += gauss(rng);
  }
  return out;
}

}  // namespace omni::detectors::testing
