#include "detectors/common/board_junction_fit.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>

#include "detectors/common/junction_lm.h"

namespace omni::detectors {
namespace {

using Vec7 = Eigen::Matrix<double, 7, 1>;
using Mat7 = Eigen::Matrix<double, 7, 7>;
using Jac = Eigen::Matrix<double, Eigen::Dynamic, 7>;

struct Pixel {
  Eigen::Vector2d x;
  double value;
};

// Along one line's normal at offset d: the board's blurred squares Q (+1 on (0, s), alternating,
// cut off where the board ends) and its blurred extent M; k = 1 / (sqrt2 blur).
struct Profile {
  double q, m;
};
Profile ProfileAt(double d, double along, double plus, double minus, double plus_tilt, double minus_tilt,
                  bool margin_plus, bool margin_minus, double k) {
  // The blurred indicator of [l, r): P(l < d + noise < r).
  const auto cdf = [&](double edge) { return 0.5 * (1 + std::erf(k * (d - edge))); };
  // Edge j at j squares on (the window's half is <= 0.8 squares and the blur under half a
  // square: squares beyond 3 do not reach it), tilted j times the neighbouring line's tilt.
  const auto edge = [&](int j) { return j >= 0 ? j * (plus + plus_tilt * along) : j * (minus - minus_tilt * along); };
  Profile p{0, 1};
  for (int j = -3; j <= 2; ++j) {  // the square [edge j, edge j + 1)
    if ((margin_plus && j >= 1) || (margin_minus && j <= -2)) continue;
    const double sign = (j % 2 == 0) ? 1.0 : -1.0;
    p.q += sign * (cdf(edge(j)) - cdf(edge(j + 1)));
  }
  p.m = (margin_minus ? cdf(-minus) : 1.0) - (margin_plus ? cdf(plus) : 0.0);
  return p;
}

double NormalCurvature(const LocalLine& l) { return l.curvature.dot(Eigen::Vector2d(-l.tangent.y(), l.tangent.x())); }

struct BoardModel {
  const std::vector<Pixel>& pixels;
  const BoardAround& board;
  double kappa[2];

  // Residuals (model - pixel) at q = (x, y, angle_row, angle_col, a, b, blur).
  Eigen::VectorXd Residuals(const Vec7& q) const {
    Eigen::VectorXd r(pixels.size());
    const double k = 1 / (std::sqrt(2.0) * q[6]);
    Eigen::Vector2d t[2], n[2];
    for (int i = 0; i < 2; ++i) {
      t[i] = Eigen::Vector2d(std::cos(q[2 + i]), std::sin(q[2 + i]));
      n[i] = Eigen::Vector2d(-t[i].y(), t[i].x());
    }
    const double plus_sides[2] = {board.row_plus, board.col_plus};
    const double minus_sides[2] = {board.row_minus, board.col_minus};
    const double plus_tilts[2] = {board.row_plus_tilt, board.col_plus_tilt};
    const double minus_tilts[2] = {board.row_minus_tilt, board.col_minus_tilt};
    const bool plus[2] = {board.margin_row_plus, board.margin_col_plus};
    const bool minus[2] = {board.margin_row_minus, board.margin_col_minus};
    for (size_t p = 0; p < pixels.size(); ++p) {
      const Eigen::Vector2d rel = pixels[p].x - q.head<2>();
      Profile f[2];
      for (int i = 0; i < 2; ++i) {
        const double along = t[i].dot(rel);
        const double d = n[i].dot(rel) - 0.5 * kappa[i] * along * along;
        f[i] = ProfileAt(d, along, plus_sides[i], minus_sides[i], plus_tilts[i], minus_tilts[i], plus[i], minus[i], k);
      }
      r[p] = q[4] + q[5] * f[0].q * f[1].q + std::abs(q[5]) * (1 - f[0].m * f[1].m) - pixels[p].value;
    }
    return r;
  }
};

}  // namespace

std::optional<BoardAround> BoardAroundCorner(const std::vector<std::optional<Eigen::Vector2d>>& corners,
                                             int rows, int cols, int id, const LocalLine& row,
                                             const LocalLine& col) {
  const int r = id / cols, c = id % cols;
  const Eigen::Vector2d& at = *corners[id];
  const auto get = [&](int rr, int cc) -> std::optional<Eigen::Vector2d> {
    if (rr < 0 || cc < 0 || rr >= rows || cc >= cols) return std::nullopt;
    return corners[rr * cols + cc];
  };
  BoardAround b;
  // Across the row line: the neighbours in the next and previous rows; which side of the
  // normal the next row lies on fixes where the first / last row's margin is.
  // The neighbours' offsets along each normal: the next one's side of it is + or -; a missing
  // neighbour's side taken from the other.
  // A neighbouring line (through corner `nb_id`, along the same direction as `own`) in the frame
  // of the corner's line: its normal offset at the corner and its tilt; nullopt where unknown.
  struct Offset {
    double at_corner, tilt;
  };
  const auto offset_of = [&](const LocalLine& own, int rr, int cc, bool along_row) -> std::optional<Offset> {
    const auto q = get(rr, cc);
    if (!q) return std::nullopt;
    const Eigen::Vector2d t = own.tangent, n(-t.y(), t.x());
    double tilt = 0;
    if (const auto line = LineThroughCorner(corners, rows, cols, rr * cols + cc, along_row);
        line && t.dot(line->tangent) > 0.5) {
      tilt = n.dot(line->tangent) / t.dot(line->tangent);
    }
    const Eigen::Vector2d rel = *q - at;
    return Offset{n.dot(rel) - tilt * t.dot(rel), tilt};
  };
  const auto across = [&](const LocalLine& own, bool along_row, int next_r, int next_c, int prev_r, int prev_c,
                          double* plus, double* minus, double* plus_tilt, double* minus_tilt, int* next_sign) {
    auto next = offset_of(own, next_r, next_c, along_row), previous = offset_of(own, prev_r, prev_c, along_row);
    if (!next && !previous) return false;
    if (!next) next = Offset{-previous->at_corner, -previous->tilt};
    if (!previous) previous = Offset{-next->at_corner, -next->tilt};
    if (next->at_corner * previous->at_corner >= 0) return false;
    *next_sign = next->at_corner > 0 ? 1 : -1;
    const Offset& p = next->at_corner > 0 ? *next : *previous;
    const Offset& m = next->at_corner > 0 ? *previous : *next;
    *plus = p.at_corner;
    *plus_tilt = p.tilt;
    *minus = -m.at_corner;
    *minus_tilt = m.tilt;
    return true;
  };
  int row_next = 0, col_next = 0;
  if (!across(row, true, r + 1, c, r - 1, c, &b.row_plus, &b.row_minus, &b.row_plus_tilt, &b.row_minus_tilt,
              &row_next) ||
      !across(col, false, r, c + 1, r, c - 1, &b.col_plus, &b.col_minus, &b.col_plus_tilt, &b.col_minus_tilt,
              &col_next)) {
    return std::nullopt;
  }
  // The margin beyond the last row lies on the next row's side, beyond the first on the other.
  (row_next > 0 ? b.margin_row_plus : b.margin_row_minus) = r == rows - 1;
  (row_next > 0 ? b.margin_row_minus : b.margin_row_plus) = r == 0;
  (col_next > 0 ? b.margin_col_plus : b.margin_col_minus) = c == cols - 1;
  (col_next > 0 ? b.margin_col_minus : b.margin_col_plus) = c == 0;
  return b;
}

std::optional<JunctionFit> FitBlurredBoardJunction(const cv::Mat& grey, const Eigen::Vector2d& start,
                                                   const LocalLine& row, const LocalLine& col,
                                                   const BoardAround& board, double half, double sigma0) {
  CV_Assert(grey.depth() == CV_8U || grey.depth() == CV_32F);
  const int reach = static_cast<int>(std::floor(half));
  const int u0 = static_cast<int>(std::lround(start.x())), v0 = static_cast<int>(std::lround(start.y()));
  if (u0 - reach - 1 < 0 || v0 - reach - 1 < 0 || u0 + reach + 1 >= grey.cols || v0 + reach + 1 >= grey.rows) {
    return std::nullopt;
  }
  std::vector<Pixel> pixels;
  for (int v = v0 - reach - 1; v <= v0 + reach + 1; ++v) {
    for (int u = u0 - reach - 1; u <= u0 + reach + 1; ++u) {
      if (std::abs(u - start.x()) > half || std::abs(v - start.y()) > half) continue;
      pixels.push_back({Eigen::Vector2d(u, v), grey.depth() == CV_8U ? grey.at<uchar>(v, u) : grey.at<float>(v, u)});
    }
  }
  if (pixels.size() < 16) return std::nullopt;
  const BoardModel model{pixels, board, {NormalCurvature(row), NormalCurvature(col)}};
  Vec7 q;
  q << start.x(), start.y(), std::atan2(row.tangent.y(), row.tangent.x()), std::atan2(col.tangent.y(), col.tangent.x()),
      0, 0, sigma0;
  // The levels, linear given the shape: least squares of a + b (Q Q + sign(b) (1 - M M)) for
  // either sign of b, the better kept.
  double best_cost = 1e300;
  Vec7 best = q;
  for (const double sign : {1.0, -1.0}) {
    Vec7 trial = q;
    trial[4] = 0;
    trial[5] = sign;
    const Eigen::VectorXd shape = model.Residuals(trial);  // b (Q Q) + |b| (1 - M M) - value, b = +-1
    Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (size_t p = 0; p < pixels.size(); ++p) {
      const Eigen::Vector2d f(1, shape[p] + pixels[p].value);  // sign Q Q + (1 - M M): times |b|
      a += f * f.transpose();
      rhs += f * pixels[p].value;
    }
    const Eigen::Vector2d levels = a.ldlt().solve(rhs);
    if (levels[1] <= 0) continue;
    trial[4] = levels[0];
    trial[5] = sign * levels[1];
    const double cost = model.Residuals(trial).squaredNorm();
    if (cost < best_cost) best_cost = cost, best = trial;
  }
  if (best_cost > 1e299) return std::nullopt;
  q = best;
  // Levenberg-Marquardt on a forward-difference Jacobian (7 parameters, ~50-100 pixels).
  const double steps[7] = {1e-4, 1e-4, 1e-5, 1e-5, 1e-3, 1e-3, 1e-4};
  const double cost = JunctionLevenbergMarquardt(
      half, best_cost,
      [&](const Vec7& at, Mat7* jtj, Vec7* jtr) {
        const Eigen::VectorXd r0 = model.Residuals(at);
        Jac j(pixels.size(), 7);
        for (int i = 0; i < 7; ++i) {
          Vec7 ai = at;
          ai[i] += steps[i];
          j.col(i) = (model.Residuals(ai) - r0) / steps[i];
        }
        *jtj = j.transpose() * j;
        *jtr = j.transpose() * r0;
      },
      [&](const Vec7& at) { return model.Residuals(at).squaredNorm(); }, &q);
  return JunctionFitOf(q, cost, pixels.size(), start, half);
}

int FitBlurredBoard(const cv::Mat& grey, int rows, int cols, const std::vector<double>& sides,
                    const std::vector<int>& start_halves, const std::vector<int>& halves, double window_squares,
                    double blur_px, std::vector<std::optional<Eigen::Vector2d>>* corners) {
  const std::vector<std::optional<Eigen::Vector2d>> measured = *corners;
  std::vector<bool> fitted(measured.size(), false);
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<std::optional<Eigen::Vector2d>> lines_from = *corners;
    for (int id = 0; id < rows * cols; ++id) {
      if (!lines_from[id]) continue;
      const auto row = LineThroughCorner(lines_from, rows, cols, id, true);
      const auto col = LineThroughCorner(lines_from, rows, cols, id, false);
      if (!row || !col) continue;
      const auto board = BoardAroundCorner(lines_from, rows, cols, id, *row, *col);
      if (!board) continue;
      double half = window_squares * sides[id];
      if (halves[id] < start_halves[id]) half = std::min(half, static_cast<double>(halves[id]));
      const Eigen::Vector2d& start = *measured[id];
      const auto fit = FitBlurredBoardJunction(grey, *lines_from[id], *row, *col, *board, half, blur_px);
      if (fit && (fit->corner - start).norm() <= std::max(0.5, 0.15 * sides[id])) {
        (*corners)[id] = fit->corner;
        fitted[id] = true;
      } else {
        (*corners)[id] = start;
        fitted[id] = false;
      }
    }
  }
  return static_cast<int>(std::count(fitted.begin(), fitted.end(), true));
}

}  // namespace omni::detectors
