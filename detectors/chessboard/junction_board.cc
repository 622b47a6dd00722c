#include "detectors/chessboard/junction_board.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/calib3d.hpp>

namespace omni::detectors {

std::optional<bool> IsXJunction(const RingView& view, const cv::Mat& trusted, const cv::Point2f& p,
                                double radius, double min_contrast, bool point_symmetric) {
  constexpr int kSamples = 24;
  radius = std::max(2.0, radius);
  const cv::Mat& grey = view.image;
  std::array<float, kSamples> v;
  for (int k = 0; k < kSamples; ++k) {
    const double a = 2 * M_PI * k / kSamples;
    const float x = p.x + static_cast<float>(radius * std::cos(a));
    const float y = p.y + static_cast<float>(radius * std::sin(a));
    if (x < 0 || y < 0 || x > grey.cols - 2 || y > grey.rows - 2) return std::nullopt;
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    for (int dy = 0; dy <= 1; ++dy) {
      for (int dx = 0; dx <= 1; ++dx) {
        if (!trusted.at<uchar>(y0 + dy, x0 + dx)) return std::nullopt;
      }
    }
    const float fx = x - x0, fy = y - y0;
    v[k] = (1 - fy) * ((1 - fx) * grey.at<uchar>(y0, x0) + fx * grey.at<uchar>(y0, x0 + 1)) +
           fy * ((1 - fx) * grey.at<uchar>(y0 + 1, x0) + fx * grey.at<uchar>(y0 + 1, x0 + 1));
  }
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  if (*hi - *lo < min_contrast) return false;
  const float mid = 0.5f * (*lo + *hi);
  int changes = 0;
  for (int k = 0; k < kSamples; ++k) changes += (v[k] > mid) != (v[(k + 1) % kSamples] > mid);
  if (changes != 4 || !point_symmetric) return changes == 4;
  constexpr int kMaxAsymmetric = 3;
  int asymmetric = 0;
  for (int k = 0; k < kSamples / 2; ++k) asymmetric += (v[k] > mid) != (v[k + kSamples / 2] > mid);
  return asymmetric <= kMaxAsymmetric;
}

bool IsJunctionNearEdge(const RingView& view, const cv::Mat& in_ring, const cv::Mat& trusted,
                        const cv::Point2f& p, double spacing, double min_contrast) {
  if (IsXJunction(view, in_ring, p, 0.35 * spacing, min_contrast).value_or(false)) return true;
  if (IsXJunction(view, trusted, p, 0.35 * spacing, min_contrast).has_value()) return false;
  return IsXJunction(view, trusted, p, 0.2 * spacing, min_contrast, true).value_or(false);
}

bool GridFromJunctions(const RingView& view, const cv::Mat& trusted, const GridExtent& grid, double spacing, int rows,
                       int cols, std::vector<cv::Point2f>* corners, std::vector<bool>* filled) {
  const int n = rows * cols;
  // Three quarters of the pattern, or all but its longest row or column: a narrow board's
  // one hidden row is a third of it (spherical 0006: a 3x10 board whose top row lies on the
  // ring's edge, 20 of 30 junctions, was refused whole). Holes must be hidden either way.
  if (grid.count > n || (4 * grid.count < 3 * n && grid.count < n - std::max(rows, cols))) return false;
  int solutions = 0;
  for (int transpose = 0; transpose < 2; ++transpose) {
    const int extent_c = transpose ? grid.b : grid.a, extent_r = transpose ? grid.a : grid.b;
    const int short_c = cols - extent_c, short_r = rows - extent_r;
    if (short_c < 0 || short_r < 0 || short_c + short_r > 1) continue;
    // The hidden row or column before (shift 1) or after (shift 0) the grid found.
    for (int shift = 0; shift <= short_c + short_r; ++shift) {
      std::vector<cv::Point2f> out(n, cv::Point2f(0, 0));
      std::vector<bool> missing(n, true);
      std::vector<cv::Point2f> at_grid, at_view;
      bool ok = true;
      for (size_t i = 0; i < grid.points.size() && ok; ++i) {
        const int c = (transpose ? grid.coords[i].y : grid.coords[i].x) + (short_c ? shift : 0);
        const int r = (transpose ? grid.coords[i].x : grid.coords[i].y) + (short_r ? shift : 0);
        const int k = r * cols + c;
        ok = missing[k];
        missing[k] = false;
        out[k] = grid.points[i];
        at_grid.emplace_back(static_cast<float>(c), static_cast<float>(r));
        at_view.push_back(grid.points[i]);
      }
      if (!ok) continue;
      if (grid.count < n) {
        const cv::Mat h = cv::findHomography(at_grid, at_view, 0);
        if (h.empty()) continue;
        std::vector<cv::Point2f> at, predicted;
        for (int k = 0; k < n; ++k) {
          if (missing[k]) at.emplace_back(static_cast<float>(k % cols), static_cast<float>(k / cols));
        }
        cv::perspectiveTransform(at, predicted, h);
        for (int k = 0, j = 0; k < n && ok; ++k) {
          if (!missing[k]) continue;
          out[k] = predicted[j++];
          ok = !IsXJunction(view, trusted, out[k], 0.35 * spacing, 0).has_value();  // hidden
        }
      }
      if (!ok) continue;
      ++solutions;
      *corners = out;
      *filled = missing;
    }
  }
  return solutions == 1;
}

}  // namespace omni::detectors
