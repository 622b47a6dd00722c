#include "detectors/lips/mirror_rim.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "detectors/lips/grey_sampling.h"

namespace omni::detectors {
namespace {

constexpr double kCoarseShorterSide = 256;  // px of the coarse search image's shorter side

// The photos' per-pixel median as float grey levels (0..255 for 8 and 16 bit alike).
cv::Mat MedianImage(const std::vector<cv::Mat>& images) {
  std::vector<cv::Mat> f(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    images[i].convertTo(f[i], CV_32F, images[i].depth() == CV_16U ? 1.0 / 257 : 1.0);
  }
  if (f.size() <= 2) {
    cv::Mat mean = f[0].clone();
    if (f.size() == 2) mean = (f[0] + f[1]) * 0.5;
    return mean;
  }
  cv::Mat median(f[0].size(), CV_32F);
  std::vector<float> values(f.size());
  const size_t mid = f.size() / 2;
  for (int y = 0; y < median.rows; ++y) {
    for (int x = 0; x < median.cols; ++x) {
      for (size_t i = 0; i < f.size(); ++i) values[i] = f[i].at<float>(y, x);
      std::nth_element(values.begin(), values.begin() + mid, values.end());
      median.at<float>(y, x) = values[mid];
    }
  }
  return median;
}

struct Circle {
  double cx = 0, cy = 0, r = 0, score = -HUGE_VAL;
};

// How much a circle looks like the rim: the mean over `samples` angles of the brightness drop
// across it (inside minus outside at +-offset, times the polarity; its highest and lowest tenths
// left out; samples outside the image count as no drop) less half the spread (MAD) of the grey
// levels just outside it. A rim scores high though a sleeve hides part of it (the mean), a circle
// over texture or a chessboard near zero (its drops alternate in sign), and a circle inside the
// mirror that follows the rim along one side loses to the rim by the scene outside it (the
// housing outside the rim is one plain surface).
double Score(const cv::Mat& img, double cx, double cy, double r, int samples, double offset,
             double polarity, std::vector<double>* drops) {
  drops->clear();
  std::vector<double> outside;
  for (int k = 0; k < samples; ++k) {
    const double a = 2 * M_PI * (k + 0.5) / samples;
    const double c = std::cos(a), s = std::sin(a);
    double in = 0, out = 0;
    if (SampleBilinear(img, cx + (r - offset) * c, cy + (r - offset) * s, &in) &&
        SampleBilinear(img, cx + (r + offset) * c, cy + (r + offset) * s, &out)) {
      drops->push_back(polarity * (in - out));
      outside.push_back(out);
    } else {
      drops->push_back(0);
    }
  }
  std::sort(drops->begin(), drops->end());
  const int trim = samples / 10;
  double sum = 0;
  for (int k = trim; k < samples - trim; ++k) sum += (*drops)[k];
  double spread = 0;
  if (outside.size() >= 2) {
    const size_t mid = outside.size() / 2;
    std::nth_element(outside.begin(), outside.begin() + mid, outside.end());
    const double median = outside[mid];
    for (double& v : outside) v = std::abs(v - median);
    std::nth_element(outside.begin(), outside.begin() + mid, outside.end());
    spread = 1.4826 * outside[mid];
  }
  return sum / (samples - 2 * trim) - 0.5 * spread;
}

// The best circle over a grid of centres and radii.
Circle SearchGrid(const cv::Mat& img, double cx0, double cy0, double half_window, double step,
                  double r_lo, double r_hi, double r_step, int samples, double polarity) {
  Circle best;
  std::vector<double> drops;
  for (double cy = cy0 - half_window; cy <= cy0 + half_window + 1e-9; cy += step) {
    for (double cx = cx0 - half_window; cx <= cx0 + half_window + 1e-9; cx += step) {
      for (double r = r_lo; r <= r_hi + 1e-9; r += r_step) {
        const double score = Score(img, cx, cy, r, samples, 1.5, polarity, &drops);
        if (score > best.score) best = Circle{cx, cy, r, score};
      }
    }
  }
  return best;
}

struct EdgePoint {
  Eigen::Vector2d p;
  double strength = 0;
};

// Per ray from the circle's centre, the steepest drop within +-band of its radius (sub-pixel).
std::vector<EdgePoint> EdgePoints(const cv::Mat& img, const Circle& c, int rays, double polarity) {
  const double band = std::max(3.0, 0.04 * c.r);
  const double step = 0.25;
  std::vector<EdgePoint> points;
  for (int k = 0; k < rays; ++k) {
    const double a = 2 * M_PI * (k + 0.5) / rays;
    const Eigen::Vector2d dir(std::cos(a), std::sin(a));
    double best = 0, best_rho = 0, prev = 0, next = 0;
    std::vector<double> d;
    for (double rho = c.r - band; rho <= c.r + band; rho += step) {
      double in = 0, out = 0;
      if (!SampleBilinear(img, c.cx + (rho - 1) * dir.x(), c.cy + (rho - 1) * dir.y(), &in) ||
          !SampleBilinear(img, c.cx + (rho + 1) * dir.x(), c.cy + (rho + 1) * dir.y(), &out)) {
        d.push_back(-HUGE_VAL);
      } else {
        d.push_back(polarity * (in - out) / 2);
      }
    }
    int at = -1;
    for (int i = 1; i + 1 < static_cast<int>(d.size()); ++i) {
      if (d[i] > best && d[i] >= d[i - 1] && d[i] >= d[i + 1]) {
        best = d[i];
        at = i;
      }
    }
    if (at < 0) continue;
    prev = d[at - 1];
    next = d[at + 1];
    // A neighbour off the image (the rim leaving the photo) has no level: no sub-pixel step.
    const double curvature = prev - 2 * best + next;
    const double shift =
        std::isfinite(prev) && std::isfinite(next) && curvature < 0 ? 0.5 * (prev - next) / curvature : 0;
    best_rho = c.r - band + (at + std::clamp(shift, -0.5, 0.5)) * step;
    points.push_back({Eigen::Vector2d(c.cx, c.cy) + best_rho * dir, best});
  }
  return points;
}

// A circle through the points by Gauss-Newton on the radial residuals with Huber weights
// (k = 1 px), from `start`; the weights of the last iteration in *weights.
Circle FitCircle(const std::vector<EdgePoint>& points, const std::vector<bool>& use, Circle start) {
  Eigen::Vector3d x(start.cx, start.cy, start.r);
  for (int iter = 0; iter < 20; ++iter) {
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < points.size(); ++i) {
      if (!use[i]) continue;
      const Eigen::Vector2d d = points[i].p - x.head<2>();
      const double dist = d.norm();
      if (dist <= 0) continue;
      const double res = dist - x(2);
      const double w = std::abs(res) <= 1.0 ? 1.0 : 1.0 / std::abs(res);
      const Eigen::Vector3d j(-d.x() / dist, -d.y() / dist, -1);
      h += w * j * j.transpose();
      g += w * j * res;
    }
    const Eigen::Vector3d step = h.ldlt().solve(-g);
    x += step;
    if (step.norm() < 1e-6) break;
  }
  return Circle{x(0), x(1), x(2), 0};
}

}  // namespace

std::string MirrorRimOptions::Check() const {
  if (!(min_radius_fraction > 0 && max_radius_fraction > min_radius_fraction)) {
    return "min_radius_fraction, max_radius_fraction: expected 0 < min < max";
  }
  if (!(centre_window_fraction >= 0 && centre_window_fraction < 0.5)) {
    return "centre_window_fraction: expected 0 <= value < 0.5";
  }
  if (rays < 36) return "rays: expected at least 36";
  if (!(min_coverage > 0 && min_coverage <= 1)) return "min_coverage: expected 0 < value <= 1";
  if (!(max_rms_px > 0)) return "max_rms_px: expected > 0";
  return "";
}

MirrorRim FindMirrorRim(const std::vector<cv::Mat>& grey_images, const MirrorRimOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) {
    throw std::invalid_argument("mirror rim options: " + error);
  }
  if (grey_images.empty()) throw std::invalid_argument("FindMirrorRim: no images");
  for (const cv::Mat& img : grey_images) {
    if (img.size() != grey_images[0].size() || img.channels() != 1) {
      throw std::invalid_argument("FindMirrorRim: grey images of one size expected");
    }
  }
  const double polarity = options.inside_brighter ? 1 : -1;
  cv::Mat median = MedianImage(grey_images);
  const double shorter = std::min(median.cols, median.rows);
  const double scale = std::min(1.0, kCoarseShorterSide / shorter);
  cv::Mat coarse;
  cv::resize(median, coarse, cv::Size(), scale, scale, cv::INTER_AREA);
  cv::GaussianBlur(coarse, coarse, cv::Size(), 1.0);
  const double half = shorter * scale / 2;
  const double cx0 = (coarse.cols - 1) / 2.0, cy0 = (coarse.rows - 1) / 2.0;
  const double window = options.centre_window_fraction * shorter * scale;
  // Coarse grid, then a finer one about its best circle.
  Circle c = SearchGrid(coarse, cx0, cy0, window, 4, options.min_radius_fraction * half,
                        options.max_radius_fraction * half, 2, 64, polarity);
  c = SearchGrid(coarse, c.cx, c.cy, 4, 1, c.r - 3, c.r + 3, 0.5, 128, polarity);
  MirrorRim rim;
  rim.contrast = c.score;
  if (!(c.score > 0)) {
    rim.why = "no circle in the search range is brighter inside than outside along most of it";
    return rim;
  }
  // Full resolution.
  cv::Mat fine;
  cv::GaussianBlur(median, fine, cv::Size(), 1.0);
  Circle full{(c.cx + 0.5) / scale - 0.5, (c.cy + 0.5) / scale - 0.5, c.r / scale, c.score};
  for (int round = 0; round < 2; ++round) {
    const std::vector<EdgePoint> points = EdgePoints(fine, full, options.rays, polarity);
    std::vector<double> strengths;
    for (const EdgePoint& p : points) strengths.push_back(p.strength);
    if (strengths.size() < 10) break;
    std::nth_element(strengths.begin(), strengths.begin() + strengths.size() / 2, strengths.end());
    const double typical = strengths[strengths.size() / 2];
    std::vector<bool> use(points.size());
    for (size_t i = 0; i < points.size(); ++i) use[i] = points[i].strength >= 0.3 * typical;
    full = FitCircle(points, use, full);
    // Drop points beyond 3 robust sigmas (a holder, a reflection across the rim) and refit.
    std::vector<double> abs_res;
    for (size_t i = 0; i < points.size(); ++i) {
      if (use[i]) abs_res.push_back(std::abs((points[i].p - Eigen::Vector2d(full.cx, full.cy)).norm() - full.r));
    }
    std::nth_element(abs_res.begin(), abs_res.begin() + abs_res.size() / 2, abs_res.end());
    const double sigma = std::max(0.1, 1.4826 * abs_res[abs_res.size() / 2]);
    for (size_t i = 0; i < points.size(); ++i) {
      if (use[i] && std::abs((points[i].p - Eigen::Vector2d(full.cx, full.cy)).norm() - full.r) >
                        3 * sigma) {
        use[i] = false;
      }
    }
    full = FitCircle(points, use, full);
    double ss = 0;
    int n = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      if (!use[i]) continue;
      const double res = (points[i].p - Eigen::Vector2d(full.cx, full.cy)).norm() - full.r;
      ss += res * res;
      ++n;
    }
    rim.edge_points = n;
    rim.rms_px = n > 0 ? std::sqrt(ss / n) : HUGE_VAL;
    rim.coverage = static_cast<double>(n) / options.rays;
    rim.contrast = typical * 2;  // the derivative over 2 px: the drop across the edge, roughly
  }
  rim.centre = Eigen::Vector2d(full.cx, full.cy);
  rim.radius_px = full.r;
  if (!std::isfinite(full.cx) || !std::isfinite(full.cy) || !std::isfinite(full.r) ||
      !std::isfinite(rim.rms_px)) {
    rim.why = "the rim's circle fit did not converge";
    return rim;
  }
  if (rim.coverage < options.min_coverage) {
    rim.why = "the rim's edge was found on " + std::to_string(static_cast<int>(100 * rim.coverage)) +
              "% of its circle (needed " + std::to_string(static_cast<int>(100 * options.min_coverage)) +
              "%): is the mirror's rim inside the photos?";
    return rim;
  }
  if (rim.rms_px > options.max_rms_px) {
    rim.why = "the rim's edge points scatter by " + std::to_string(rim.rms_px) +
              " px about the circle: no clear circular rim";
    return rim;
  }
  rim.found = true;
  return rim;
}

}  // namespace omni::detectors
