// A chessboard corner fitted as a blurred patch of its board, for squares small against the
// blur: the webcam's inner ring (squares of 5-9 raw px under a blur sigma of 1.5-1.8 raw px).
//
// FitBlurredJunction (corner_refine.h) models a corner as two infinite blurred edges crossing
// (a + b erf erf). Where a square is under ~6 blur sigmas wide, its far edges -- the
// neighbouring junctions' lines -- reach into the window, and on the board's outer rows and
// columns so does the white margin: the blur lifts the outer dark squares towards it (proto1280's
// ring 2: 122 of 129 lost chessboard corners sat on a board's border; those kept there were
// 0.25 px from the truth against 0.12 px inside).
// This model is the board itself blurred: along each line's normal the alternating squares
// (edges at 0, +-s, +-2s, +-3s: s the local square side across that line) cut off where the
// board ends, the margin as bright as the bright squares. With a Gaussian blur of s px and the
// board's edges parallel to its lines, the blurred image is separable:
//   I = a + b Q_row(d1) Q_col(d2) + |b| (1 - M_row(d1) M_col(d2)),
// Q the blurred (square wave x board extent), M the blurred board extent, d1, d2 the signed
// offsets from the corner's two lines (parabolas, curvature held as FitBlurredJunction's).
// Exact for a Gaussian blur of a board whose lines are perpendicular (a drawn board: border
// corners 0.168 -> 0.005 px); with perspective the lines' skew and convergence are approximated
// (0.230 -> 0.135 px with noise; board_junction_fit_test). Assumes the sheet's margin is as bright
// as the light squares and at least ~1.2 squares wide beyond the 0.8-square window's reach
// (the rendered targets': one square); a board cut at its squares would need its surround.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "detectors/common/corner_refine.h"

namespace omni::detectors {

// The board around one corner: the square sides across each line (raw px) and where the board
// ends. `row` is the line along the corner's row: d1 (its normal's side) steps across rows.
struct BoardAround {
  // Px to the neighbouring row's line on the + and - side of d1 (perspective and the mirror
  // make them differ), and to the neighbouring column's on either side of d2.
  double row_plus = 0, row_minus = 0;
  double col_plus = 0, col_minus = 0;
  // The neighbouring lines' tilts against the corner's own (their normal offset's change per px
  // along it; perspective converges them): the next rows' lines at j squares on lie at
  // j (side + tilt along) (linear in j: a pencil of lines).
  double row_plus_tilt = 0, row_minus_tilt = 0;
  double col_plus_tilt = 0, col_minus_tilt = 0;
  // The margin one square on, per direction of each line's normal (+ / - side of d1, d2).
  bool margin_row_plus = false, margin_row_minus = false;
  bool margin_col_plus = false, margin_col_minus = false;
};

// The BoardAround of corner (r, c) of a rows x cols grid that is the whole pattern (ids from a
// target's lattice, not a partial grid): sides from its measured neighbours (nullopt where
// neither neighbour across a line is known or both lie on one side), the margins on the sides where r or c is the first
// or last.
std::optional<BoardAround> BoardAroundCorner(const std::vector<std::optional<Eigen::Vector2d>>& corners,
                                             int rows, int cols, int id, const LocalLine& row,
                                             const LocalLine& col);

// Levenberg-Marquardt from `start` (lines row / col, blur sigma0) over the pixels within `half`
// (px, Chebyshev). nullopt if the window leaves the image, holds under 16 pixels, or the fit
// leaves the window.
std::optional<JunctionFit> FitBlurredBoardJunction(const cv::Mat& grey, const Eigen::Vector2d& start,
                                                   const LocalLine& row, const LocalLine& col,
                                                   const BoardAround& board, double half, double sigma0);

// A board whose measured blur sigma (RingView::RawBlurAt) exceeds this fraction of its square
// side has its far edges within 3 sigmas of the 0.55-square window FitBlurredJunction reads.
constexpr double kBlurredBoardFraction = 0.15;
// The model holds the far edges and the margin, so its window may reach beyond the corner's
// four squares: more pixels against the noise. proto1280's ring-2 chessboards, mean error
// against the truth: 0.55 squares 0.163 px, 0.8 squares 0.133 px, 1.1 squares 0.146 px.
constexpr double kBlurredBoardWindowSquares = 0.8;

// Every known corner of a whole pattern's grid (rows x cols, ids from its lattice) fitted by
// FitBlurredBoardJunction from where it is, its lines and sides from the measured neighbours
// (all taken before any corner moves; twice), in a window of half window_squares * side, or
// halves[id] where that is smaller than `start_halves[id]` (a foreign edge narrowed it), blur
// sigma0 `blur_px`. A corner the fit cannot place, or moves further than max(0.5 px, 0.15
// squares), keeps its place. Returns the number fitted.
int FitBlurredBoard(const cv::Mat& grey, int rows, int cols, const std::vector<double>& sides,
                    const std::vector<int>& start_halves, const std::vector<int>& halves, double window_squares,
                    double blur_px, std::vector<std::optional<Eigen::Vector2d>>* corners);

}  // namespace omni::detectors
