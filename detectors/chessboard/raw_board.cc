#include "detectors/chessboard/raw_board.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include "detectors/chessboard/chessboard_trace.h"

namespace omni::detectors {
namespace {

// Mean grey level of the (2 half + 1)^2 box about p; nullopt where it leaves the photo.
std::optional<double> BoxMean(const cv::Mat& grey, const Eigen::Vector2d& p, int half) {
  const int u0 = static_cast<int>(std::lround(p.x())), v0 = static_cast<int>(std::lround(p.y()));
  if (u0 - half < 0 || v0 - half < 0 || u0 + half >= grey.cols || v0 + half >= grey.rows) {
    return std::nullopt;
  }
  double sum = 0;
  for (int v = v0 - half; v <= v0 + half; ++v) {
    for (int u = u0 - half; u <= u0 + half; ++u) sum += grey.at<uchar>(v, u);
  }
  return sum / ((2 * half + 1) * (2 * half + 1));
}

// The grid step along columns (dc) or rows (dr) at (r, c): central difference where both
// neighbours exist, else one-sided.
Eigen::Vector2d Step(const std::vector<Eigen::Vector2d>& p, int rows, int cols, int r, int c,
                     bool along_cols) {
  auto at = [&](int rr, int cc) { return p[rr * cols + cc]; };
  if (along_cols) {
    if (c > 0 && c + 1 < cols) return 0.5 * (at(r, c + 1) - at(r, c - 1));
    return c + 1 < cols ? at(r, c + 1) - at(r, c) : at(r, c) - at(r, c - 1);
  }
  if (r > 0 && r + 1 < rows) return 0.5 * (at(r + 1, c) - at(r - 1, c));
  return r + 1 < rows ? at(r + 1, c) - at(r, c) : at(r, c) - at(r - 1, c);
}

}  // namespace

bool IsXJunction(double q_pp, double q_pm, double q_mp, double q_mm) {
  const double apart = std::abs((q_pp + q_mm) - (q_pm + q_mp)) / 2;
  const double within = std::max(std::abs(q_pp - q_mm), std::abs(q_pm - q_mp));
  return within < apart;
}

std::optional<BoardDetection> FindBoardInPhoto(const cv::Mat& photo_grey, const cv::Mat& raw_grey,
                                               const RigModel& model, const TargetSpec& spec,
                                               int target, double blur_px,
                                               const ChessboardOptions& options) {
  CV_Assert(photo_grey.type() == CV_8UC1);
  const int rows = spec.rows, cols = spec.cols;
  // The finder's grid: its rows run along patternSize.width; rows and columns either way round.
  std::vector<cv::Point2f> found;
  bool transposed = false;
  const int flags = cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY;
  if (!cv::findChessboardCornersSB(photo_grey, cv::Size(cols, rows), found, flags)) {
    if (rows == cols || !cv::findChessboardCornersSB(photo_grey, cv::Size(rows, cols), found, flags)) {
      trace::Line("photo: the sector finder found no %dx%d board", rows, cols);
      return std::nullopt;
    }
    transposed = true;
  }
  if (static_cast<int>(found.size()) != rows * cols) return std::nullopt;
  std::vector<Eigen::Vector2d> grid(rows * cols);
  for (int k = 0; k < rows * cols; ++k) {
    // Finder index k: (k / w, k % w) with w its patternSize.width.
    const int a = k / (transposed ? rows : cols), b = k % (transposed ? rows : cols);
    const int r = transposed ? b : a, c = transposed ? a : b;
    grid[r * cols + c] = Eigen::Vector2d(found[k].x, found[k].y);
  }
  // Every corner an X-junction of the photo, seen through the mirror.
  std::vector<Eigen::Vector3d> rays(grid.size());
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector2d p = grid[r * cols + c];
      const Eigen::Vector2d dc = Step(grid, rows, cols, r, c, true);
      const Eigen::Vector2d dr = Step(grid, rows, cols, r, c, false);
      const int half = std::max(1, static_cast<int>(0.08 * std::min(dc.norm(), dr.norm())));
      const auto pp = BoxMean(photo_grey, p + 0.3 * (dc + dr), half);
      const auto pm = BoxMean(photo_grey, p + 0.3 * (dc - dr), half);
      const auto mp = BoxMean(photo_grey, p - 0.3 * (dc - dr), half);
      const auto mm = BoxMean(photo_grey, p - 0.3 * (dc + dr), half);
      if (!pp || !pm || !mp || !mm || !IsXJunction(*pp, *pm, *mp, *mm)) {
        trace::Line("photo: %dx%d board refused: corner (%d, %d) at %.1f,%.1f is no X-junction",
                    rows, cols, r, c, p.x(), p.y());
        return std::nullopt;
      }
      const auto ray = model.Unproject(p);
      if (!ray || ray->mirror != Mirror::kOne) {
        trace::Line("photo: %dx%d board refused: corner (%d, %d) sees no mirror", rows, cols, r, c);
        return std::nullopt;
      }
      rays[r * cols + c] = ray->ray.direction.normalized();
    }
  }
  // A proper labelling: (column steps x row steps) . mean ray > 0, as a view's un-mirrored
  // picture has it (chessboard_detector.h), else the columns reversed; then of it and its
  // 180-degree turn the one whose rows rise along +z_C.
  Eigen::Vector3d col_steps = Eigen::Vector3d::Zero(), row_steps = Eigen::Vector3d::Zero(),
                  mean = Eigen::Vector3d::Zero();
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      mean += rays[r * cols + c];
      if (c + 1 < cols) col_steps += rays[r * cols + c + 1] - rays[r * cols + c];
      if (r + 1 < rows) row_steps += rays[(r + 1) * cols + c] - rays[r * cols + c];
    }
  }
  const bool reverse_cols = col_steps.cross(row_steps).dot(mean) < 0;
  // Reversing the columns reverses col_steps; a 180-degree turn reverses both.
  const bool turn = row_steps.z() < 0;
  std::vector<std::optional<Eigen::Vector2d>> raw(grid.size());
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      int rr = r, cc = reverse_cols ? cols - 1 - c : c;
      if (turn) {
        rr = rows - 1 - rr;
        cc = cols - 1 - cc;
      }
      raw[r * cols + c] = grid[rr * cols + cc];
    }
  }
  const RawRefinement refinement = RefineBoardInRaw(raw_grey, model, spec, raw, blur_px, options);
  BoardDetection board;
  board.target = target;
  board.mirror = Mirror::kOne;
  for (size_t i = 0; i < raw.size(); ++i) {
    if (!refinement.refined[i]) continue;
    board.ids.push_back(static_cast<int>(i));
    board.raw_pixels.push_back(*refinement.refined[i]);
    board.view_pixels.push_back(*raw[i]);  // no view: the finder's pixel
  }
  trace::Line("photo: %dx%d board found by the sector finder: %zu corners (refused: refine %d, "
              "moved %d, window %d)",
              rows, cols, board.ids.size(), refinement.refused_refine, refinement.refused_shift,
              refinement.refused_window);
  if (2 * board.ids.size() < raw.size()) return std::nullopt;
  return board;
}

}  // namespace omni::detectors
