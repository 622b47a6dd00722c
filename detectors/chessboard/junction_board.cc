#include "detectors/chessboard/junction_board.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/chessboard/chessboard_trace.h"

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

namespace {

// One placement of the grid found inside the rows x cols pattern: the grid's point with grid
// coordinates (x, y) is the pattern's corner (row y + off_r, col x + off_c), or (x + off_r,
// y + off_c) transposed. Missing corners are taken from `loose` where the homography of the
// corners placed so far predicts one there (a cluster beyond a post's band), the rest must be
// hidden, or (min_contrast >= 0) show an X-junction at the prediction, which is taken. False if
// a missing corner is in plain sight otherwise.
bool Place(const RingView& view, const cv::Mat& trusted, const GridExtent& grid,
           const std::vector<cv::Point2f>& loose, double spacing, double min_contrast, int rows, int cols,
           bool transpose, int off_r, int off_c, std::vector<cv::Point2f>* out, std::vector<bool>* missing) {
  const int n = rows * cols;
  out->assign(n, cv::Point2f(0, 0));
  missing->assign(n, true);
  std::vector<cv::Point2f> at_grid, at_view;
  for (size_t i = 0; i < grid.points.size(); ++i) {
    const int c = (transpose ? grid.coords[i].y : grid.coords[i].x) + off_c;
    const int r = (transpose ? grid.coords[i].x : grid.coords[i].y) + off_r;
    const int k = r * cols + c;
    if (!(*missing)[k]) return false;
    (*missing)[k] = false;
    (*out)[k] = grid.points[i];
    at_grid.emplace_back(static_cast<float>(c), static_cast<float>(r));
    at_view.push_back(grid.points[i]);
  }
  if (static_cast<int>(at_grid.size()) == n) return true;
  std::vector<bool> used(loose.size(), false);
  // Junctions across a gap are taken a few at a time: each round's homography includes the
  // previous rounds' (a post's band is 1-3 squares wide; the prediction across it from one side's
  // grid is within a tenth of a square in a perspective view).
  for (int round = 0; round < 4; ++round) {
    const cv::Mat h = cv::findHomography(at_grid, at_view, 0);
    if (h.empty()) return false;
    std::vector<cv::Point2f> at, predicted;
    std::vector<int> which;
    for (int k = 0; k < n; ++k) {
      if (!(*missing)[k]) continue;
      at.emplace_back(static_cast<float>(k % cols), static_cast<float>(k / cols));
      which.push_back(k);
    }
    if (at.empty()) break;  // every corner taken
    cv::perspectiveTransform(at, predicted, h);
    bool taken = false;
    for (size_t j = 0; j < which.size(); ++j) {
      (*out)[which[j]] = predicted[j];
      int best = -1;
      double best_d = 0.3 * spacing;
      for (size_t q = 0; q < loose.size(); ++q) {
        const double d = cv::norm(loose[q] - predicted[j]);
        if (!used[q] && d < best_d) {
          best = static_cast<int>(q);
          best_d = d;
        }
      }
      if (best < 0) continue;
      used[best] = true;
      (*missing)[which[j]] = false;
      (*out)[which[j]] = loose[best];
      at_grid.push_back(at[j]);
      at_view.push_back(loose[best]);
      taken = true;
    }
    if (!taken) break;
  }
  // Every corner still missing must be hidden: its circle reaches past the trusted pixels (the
  // ring's edge, a post's band: both are outside the view's map, with the edge margin) or the
  // view. Or the view shows an X-junction at the prediction (point-symmetric, as two lines
  // crossing): a corner the saddle detector missed (a blurred inner ring: under its contrast),
  // taken at the prediction for the refinement.
  for (int k = 0; k < n; ++k) {
    if (!(*missing)[k]) continue;
    const std::optional<bool> x =
        IsXJunction(view, trusted, (*out)[k], 0.35 * spacing, std::max(0.0, min_contrast), true);
    if (!x) continue;
    if (*x && min_contrast >= 0) {
      (*missing)[k] = false;
      continue;
    }
    trace::Line("    placement %s+%d+%d: corner (%d, %d) at %.1f,%.1f in plain sight, no junction",
                transpose ? "T" : "", off_r, off_c, k / cols, k % cols, (*out)[k].x, (*out)[k].y);
    return false;
  }
  return true;
}

}  // namespace

GridExtent TrustedPart(const RingView& view, const cv::Mat& trusted, const GridExtent& grid, double spacing) {
  GridExtent out;
  cv::Point low(INT_MAX, INT_MAX), high(INT_MIN, INT_MIN);
  for (size_t i = 0; i < grid.points.size(); ++i) {
    if (!IsXJunction(view, trusted, grid.points[i], 0.35 * spacing, 0).has_value()) continue;
    out.points.push_back(grid.points[i]);
    out.coords.push_back(grid.coords[i]);
    low = cv::Point(std::min(low.x, grid.coords[i].x), std::min(low.y, grid.coords[i].y));
    high = cv::Point(std::max(high.x, grid.coords[i].x), std::max(high.y, grid.coords[i].y));
  }
  out.count = static_cast<int>(out.points.size());
  if (out.count == 0) return {};
  for (cv::Point& c : out.coords) c -= low;
  out.a = high.x - low.x + 1;
  out.b = high.y - low.y + 1;
  out.box = cv::boundingRect(out.points);
  return out;
}

bool GridFromJunctions(const RingView& view, const cv::Mat& trusted, const GridExtent& grid, double spacing, int rows,
                       int cols, const JunctionGaps* gaps, std::vector<cv::Point2f>* corners,
                       std::vector<bool>* filled, int* placements) {
  if (placements) *placements = 0;
  const int n = rows * cols;
  if (grid.count > n) return false;
  if (gaps) {
    // A grid of one row or column fixes no homography.
    if (grid.count < 4 || grid.a < 2 || grid.b < 2) return false;
  } else if (4 * grid.count < 3 * n && grid.count < n - std::max(rows, cols)) {
    // Three quarters of the pattern, or all but its longest row or column: a narrow board's
    // one hidden row is a third of it (spherical 0006: a 3x10 board whose top row lies on the
    // ring's edge, 20 of 30 junctions, was refused whole). Holes must be hidden either way.
    return false;
  }
  static const std::vector<cv::Point2f> kNone;
  const std::vector<cv::Point2f>& loose = gaps ? gaps->loose : kNone;
  const double min_contrast = gaps ? gaps->min_contrast : -1;
  int solutions = 0;
  // Across gaps, a square pattern's transposed placements are its placements relabelled
  // (Orient's 90-degree turns and its handedness): only one way round.
  for (int transpose = 0; transpose < (gaps && rows == cols ? 1 : 2); ++transpose) {
    const int extent_c = transpose ? grid.b : grid.a, extent_r = transpose ? grid.a : grid.b;
    const int short_c = cols - extent_c, short_r = rows - extent_r;
    if (short_c < 0 || short_r < 0 || (!gaps && short_c + short_r > 1)) continue;
    for (int off_r = 0; off_r <= short_r; ++off_r) {
      for (int off_c = 0; off_c <= short_c; ++off_c) {
        std::vector<cv::Point2f> out;
        std::vector<bool> missing;
        if (!Place(view, trusted, grid, loose, spacing, min_contrast, rows, cols, transpose, off_r, off_c, &out,
                   &missing)) {
          continue;
        }
        // Across gaps: half the pattern in plain sight at least.
        const int seen = n - static_cast<int>(std::count(missing.begin(), missing.end(), true));
        if (gaps && 2 * seen < n) continue;
        ++solutions;
        *corners = out;
        *filled = missing;
      }
    }
  }
  if (placements) *placements = solutions;
  return solutions == 1;
}

}  // namespace omni::detectors
