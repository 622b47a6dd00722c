#include "detectors/chessboard/grid_check.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

#include "detectors/chessboard/chessboard_trace.h"

namespace omni::detectors {

void AddSmoothCorrection(const std::vector<cv::Point2f>& grid_in, const std::vector<cv::Point2f>& view_in,
                         const cv::Mat& h, const std::vector<cv::Point2f>& grid,
                         std::vector<cv::Point2f>* predicted) {
  constexpr int kQuadratic = 6, kCubic = 10;
  const int terms_used = grid_in.size() >= 2 * kCubic ? kCubic : kQuadratic;
  if (grid_in.size() < 2 * static_cast<size_t>(terms_used)) return;
  const auto terms = [terms_used](const cv::Point2f& g) {
    Eigen::VectorXd t(terms_used);
    const double x = g.x, y = g.y;
    t.head<kQuadratic>() << 1, x, y, x * x, x * y, y * y;
    if (terms_used == kCubic) t.tail<kCubic - kQuadratic>() << x * x * x, x * x * y, x * y * y, y * y * y;
    return t;
  };
  std::vector<cv::Point2f> fitted;
  cv::perspectiveTransform(grid_in, fitted, h);
  Eigen::MatrixXd a(grid_in.size(), terms_used);
  Eigen::MatrixXd b(grid_in.size(), 2);
  for (size_t i = 0; i < grid_in.size(); ++i) {
    a.row(static_cast<Eigen::Index>(i)) = terms(grid_in[i]).transpose();
    b(static_cast<Eigen::Index>(i), 0) = view_in[i].x - fitted[i].x;
    b(static_cast<Eigen::Index>(i), 1) = view_in[i].y - fitted[i].y;
  }
  const Eigen::MatrixXd coeffs = a.colPivHouseholderQr().solve(b);
  for (size_t i = 0; i < grid.size(); ++i) {
    const Eigen::Vector2d d = coeffs.transpose() * terms(grid[i]);
    (*predicted)[i] += cv::Point2f(static_cast<float>(d.x()), static_cast<float>(d.y()));
  }
}

bool GridFitsBoard(const RingView& view, const RigModel& model, int cols,
                   const ChessboardOptions& options, BoardDetection* board) {
  const size_t n = board->ids.size();
  if (n < 4) return false;
  std::vector<cv::Point2f> grid, in_view;
  for (size_t i = 0; i < n; ++i) {
    const auto p = view.RawToView(model, board->raw_pixels[i]);
    if (!p) return false;
    grid.emplace_back(static_cast<float>(board->ids[i] % cols), static_cast<float>(board->ids[i] / cols));
    in_view.emplace_back(static_cast<float>(p->x()), static_cast<float>(p->y()));
  }
  // The square side in the view from the corners' grid neighbours (median), and each corner's
  // shortest side in the raw image.
  std::vector<double> sides, raw_side(n, 1e9);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      if (std::abs(grid[i].x - grid[j].x) + std::abs(grid[i].y - grid[j].y) == 1) {
        sides.push_back(cv::norm(in_view[i] - in_view[j]));
        const double raw = (board->raw_pixels[i] - board->raw_pixels[j]).norm();
        raw_side[i] = std::min(raw_side[i], raw);
        raw_side[j] = std::min(raw_side[j], raw);
      }
    }
  }
  // The test's tolerance per corner: with the smooth correction (a start model's error), also
  // a fraction of the corner's square: the model's error over a board grows with the board's
  // image, a mis-ordered corner is a third of a square off or more.
  const auto tolerance = [&](size_t i) {
    return options.smooth_grid_correction
               ? std::max(options.max_grid_residual_px, options.max_grid_residual_squares * raw_side[i])
               : options.max_grid_residual_px;
  };
  if (sides.empty()) return false;
  std::nth_element(sides.begin(), sides.begin() + sides.size() / 2, sides.end());
  const double side = sides[sides.size() / 2];
  // RANSAC with a loose tolerance finds the board's homography among mis-ordered corners; the
  // test itself is in raw pixels (the views magnify the inner ring 2-3 times): the homography's
  // prediction mapped to the raw image must lie within max_grid_residual_px of the refined
  // corner. A corner on a neighbouring saddle is a square (>= 2.5 raw px) off, a mis-ordered
  // one ~1 px, one pulled by the ring's edge 0.7-1 px; good ones < 0.3 px.
  cv::Mat inlier_mask;
  cv::Mat h = cv::findHomography(grid, in_view, cv::RANSAC, options.max_grid_ransac_squares * side,
                                 inlier_mask, 500, 0.999);
  if (h.empty()) return false;
  std::vector<cv::Point2f> grid_in, view_in;
  for (size_t i = 0; i < n; ++i) {
    if (inlier_mask.at<uchar>(static_cast<int>(i))) {
      grid_in.push_back(grid[i]);
      view_in.push_back(in_view[i]);
    }
  }
  // Least squares on the inliers, then again on the corners within the test's tolerance (corners
  // biased by the ring's edge pull a fit that includes them).
  std::vector<bool> keep(n);
  size_t kept = 0;
  for (int round = 0; round < 3; ++round) {
    if (grid_in.size() < 4) return false;
    h = cv::findHomography(grid_in, view_in, 0);
    if (h.empty()) return false;
    std::vector<cv::Point2f> predicted;
    cv::perspectiveTransform(grid, predicted, h);
    if (options.smooth_grid_correction) AddSmoothCorrection(grid_in, view_in, h, grid, &predicted);
    kept = 0;
    grid_in.clear();
    view_in.clear();
    std::vector<double> residuals;  // for the trace
    for (size_t i = 0; i < n; ++i) {
      const auto raw = view.ViewToRaw(Eigen::Vector2d(predicted[i].x, predicted[i].y));
      residuals.push_back(raw ? (*raw - board->raw_pixels[i]).norm() : -1);
      keep[i] = raw && (*raw - board->raw_pixels[i]).norm() <= tolerance(i);
      if (!keep[i]) continue;
      ++kept;
      grid_in.push_back(grid[i]);
      view_in.push_back(in_view[i]);
    }
    if (trace::On()) {
      std::string line;
      for (double r : residuals) line += cv::format("%.2f ", r);
      trace::Line("   round %d: kept %zu of %zu; residuals %s", round, kept, n, line.c_str());
    }
  }
  if (kept < 4 || static_cast<double>(kept) < options.min_grid_inlier_fraction * n) return false;
  BoardDetection out = *board;
  out.ids.clear();
  out.view_pixels.clear();
  out.raw_pixels.clear();
  for (size_t i = 0; i < n; ++i) {
    if (!keep[i]) continue;
    out.ids.push_back(board->ids[i]);
    out.view_pixels.push_back(board->view_pixels[i]);
    out.raw_pixels.push_back(board->raw_pixels[i]);
  }
  *board = std::move(out);
  return true;
}

}  // namespace omni::detectors
