// Sub-pixel refinement of chessboard corners in the raw image, and the removal of its curvature
// bias.
//
// cv::cornerSubPix puts a corner where the tangent lines of the edge pixels in its window meet.
// Through the mirrors a board's straight rows and columns image as curves ([m1], [m2] are not
// projective), and the tangent at arc length s from the corner passes k s^2 / 2 beside it on the
// convex side, so the refined corner moves away from the centres of curvature: +0.02 px radially
// in both rings of the big rig with the detector's window (bench/render_bias, exact box-filtered
// pixels), which a calibration absorbs into the axial parameters (fx, k1, mirror tz, reflex dz).
//
// The correction is a prediction of that bias by the same refinement on a model of the corner:
// each of the two grid lines through it is a parabola (tangent and curvature from the board's
// neighbouring refined corners, three consecutive ones along the row and along the column), the
// model junction is box-filtered exactly at the corner's sub-pixel phase, cornerSubPix runs on it
// from the model's own corner, and the offset it finds is subtracted from the measured corner.
// The model carries whatever cornerSubPix does (window weights, discrete pixels, line angles);
// only the lines' shapes come from the image.
//
// Pixel scales: raw pixels; the bias it removes is a few hundredths of a pixel. Failure modes: a
// corner with no refined neighbour along both of its lines is left uncorrected (one neighbour: a
// straight line); a window cut by the ring's edge moves a corner 1.5-3 px (tag_grid_check.h
// drops those).
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace omni::detectors {

// cv::cornerSubPix of one corner in a grey image with a (2 half + 1)^2 window, started at
// *pixel. False (pixel unchanged) if the window does not fit in the image.
bool RefineCornerInRaw(const cv::Mat& grey, int half, Eigen::Vector2d* pixel);

// A grid line through a corner, locally: unit tangent and curvature vector (1/px, pointing to
// the centre of curvature; zero for a straight line).
struct LocalLine {
  Eigen::Vector2d tangent = Eigen::Vector2d::UnitX();
  Eigen::Vector2d curvature = Eigen::Vector2d::Zero();
};

// The offset cv::cornerSubPix (half-window `half`) converges to from the true corner `corner`
// of an ideal junction of two curved lines (exact box-filtered pixels).
Eigen::Vector2d PredictedRefineBias(const Eigen::Vector2d& corner, const LocalLine& row,
                                    const LocalLine& col, int half);

// The line through corner `id` of a rows x cols board along its row (along_row) or column, from
// three consecutive corners of `corners` (row-major by id, nullopt where unknown): the triple
// centred on it, else the one beside it at a board's edge or a gap. With only one neighbour:
// a straight line through the two. nullopt without any neighbour along the line.
std::optional<LocalLine> LineThroughCorner(const std::vector<std::optional<Eigen::Vector2d>>& corners,
                                           int rows, int cols, int id, bool along_row);

// Corners refined from known starting points as the chessboard detector refines a board's
// (bench/render_bias: the refinement's bias on exact images): each corner by RefineCornerInRaw
// with its half window from its start (nullopt where the window comes within 3 px of the border
// or cornerSubPix refuses), then with `correct` each board's RemoveCurvatureBias. Board b is
// board_sizes[b] = (rows, cols); a corner's id is row-major on its board.
struct CornerStart {
  int board = 0, id = 0;
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  int half = 1;
};
std::vector<std::optional<Eigen::Vector2d>> RefineFromStarts(
    const cv::Mat& grey, const std::vector<std::pair<int, int>>& board_sizes,
    const std::vector<CornerStart>& corners, bool correct);

// Subtracts PredictedRefineBias from each known corner of a board refined by RefineCornerInRaw
// with half-windows `halves` (per id). Lines are taken from the corners as given (all before
// any correction). Corners without a neighbour along both lines are left as they are.
void RemoveCurvatureBias(int rows, int cols, const std::vector<int>& halves,
                         std::vector<std::optional<Eigen::Vector2d>>* corners);

// The largest half-window <= `half` whose cornerSubPix window around `corner` (with the one-pixel
// border its gradients read and the half pixel its interpolation adds) shows nothing but the
// corner's own four squares. The two grid lines through the corner split the window into two
// dark and two bright quadrants (levels: the median of each pair); a pixel more than b px from
// both lines and less than `side` - b px from them (b = max(1.5, 1.3 blur_px): a blurred
// junction's product of two edges is within 35% of its quadrant's level from there on) (inside the four squares, not on a blurred
// edge) must match its quadrant's level to within 35% of the contrast, or be on a slope under
// `min_foreign_slope` times the board's own edges' (shading, a glossy sheet's sheen). One that does not (the
// ring's rim or lip, a board sheet's edge, an occluder) is an edge cornerSubPix would take as one
// of the corner's: the window is bounded to leave it out. `half` if nothing is found or nothing
// can be judged (squares too small, no contrast).
// `grey`: CV_8U or CV_32F.
// `min_foreign_slope`: where the board's contrast is at 93% of its peak slope off its level, a
// step of c times the contrast is at 0.93 c: 0.5 takes steps of over 0.54 of the board's contrast
// for foreign (the folded rig's painted lips beside ring 1's boards: at 0.6 they were let in
// and moved corners by up to 0.06 px), 0.7 those over 0.75 (a single mirror's dark rim band is
// the whole contrast, and its boards' sheen in linear light is steeper: Mei's photos, 458 of 480
// corners kept at 0.5, 471 at 0.7).
int CleanHalfWindow(const cv::Mat& grey, const Eigen::Vector2d& corner, const LocalLine& row,
                    const LocalLine& col, double side, int half, double blur_px = 0,
                    double min_foreign_slope = 0.5);

// Every known corner of a board refined by RefineCornerInRaw (half-windows `halves`, local
// square sides `sides`, per id) whose window takes in something besides its own four squares
// (CleanHalfWindow, lines from the refined neighbours) is refined again from where it is with
// the clean half-window, or dropped (nullopt) if that is below min(`min_half`, its half): a
// corner a foreign edge pulled (0.5-0.9 px: the demo's board cut by ring 1's lip) is better
// absent than wrong. Returns the number of corners dropped.
// A blurred X-junction fitted to the pixels: the model a camera images a chessboard corner as.
//   I(x) = a + b erf(d1 / (sqrt2 s)) erf(d2 / (sqrt2 s)),
// d1, d2 the signed offsets of the pixel centre x from the corner's two grid lines, each a
// parabola through the corner (its tangent angle fitted, its curvature given: LocalLine); a
// Gaussian blur of s px (the lens's defocus, the demosaicing, the pixel's box; fitted) moves a
// curved edge's halfway level s^2 k / 2 towards its centre of curvature, which d1, d2 carry.
// The product is exact for a Gaussian-blurred junction of perpendicular lines and otherwise
// has the junction's point symmetry, so its centre is where the junction's is.
// Why not cornerSubPix: its equations use every gradient's direction, and in small blurred
// squares (the inner ring's 4-6 px) the demosaicing's colour errors along an edge and the
// neighbouring edges' blur turn those directions: realistic_scene ring 2, 0.09 px mean from
// cornerSubPix against 0.035 from this fit on the same corners. Fitting the levels themselves
// averages such errors over the edge.
struct JunctionFit {
  Eigen::Vector2d corner = Eigen::Vector2d::Zero();
  double sigma = 0;     // fitted blur (px)
  double contrast = 0;  // |b|: half the difference between the bright and dark squares
  double rms = 0;       // of the pixel residuals (grey levels)
};

// Levenberg-Marquardt from `start` over the pixels within `half` (px, Chebyshev) of it;
// row / col give the lines' tangents to start from and their curvatures (held). nullopt if the
// window leaves the image, holds under 16 pixels, or the fit leaves the window.
std::optional<JunctionFit> FitBlurredJunction(const cv::Mat& grey, const Eigen::Vector2d& start,
                                              const LocalLine& row, const LocalLine& col,
                                              double half, double sigma0 = 1.0);

// Every known corner of a board refined by RefineCornerInRaw (half-windows `halves`, local
// square sides `sides`, per id) fitted by FitBlurredJunction from where it is, its lines from
// the refined neighbours (all taken before any corner moves), in a window of half
// min(window_squares * side, halves[id]) (KeepWindowsOnTheirSquares may have narrowed it).
// Where the fit is not possible (small squares, no neighbours along both lines) or moves the
// corner further than max(0.5 px, 0.15 squares) (it then did not fit that junction), the corner
// gets the curvature-bias correction of RemoveCurvatureBias instead. Returns the number fitted.
int FitBoardJunctions(const cv::Mat& grey, int rows, int cols, const std::vector<double>& sides,
                      const std::vector<int>& halves, double window_squares,
                      std::vector<std::optional<Eigen::Vector2d>>* corners);

// `blur_px`: the image's blur sigma there in pixels (RingView::RawBlurAt; 0: sharp);
// `min_foreign_slope`: as CleanHalfWindow.
int KeepWindowsOnTheirSquares(const cv::Mat& grey, int rows, int cols, const std::vector<double>& sides,
                              int min_half, std::vector<int>* halves,
                              std::vector<std::optional<Eigen::Vector2d>>* corners, double blur_px = 0,
                              double min_foreign_slope = 0.5);

}  // namespace omni::detectors
