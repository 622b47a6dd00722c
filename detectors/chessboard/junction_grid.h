// The lattice of a saddle region's X-junctions (chessboard_detector.cc): integer grid coordinates
// given by growing from a seed junction, each step predicted from the step its parent took in
// that direction (a perspective grid changes slowly from corner to corner).
//
// A grid step must run along one of the board's lines: between two neighbouring junctions of
// a chessboard lies the edge between a dark and a light square, while a diagonal step crosses a
// square's plain inside (IsEdgeStep). Without that test the growth took diagonals for steps
// wherever a board seen obliquely makes a square's diagonal shorter than its sides (the far rows
// of a board held flat below a single mirror: Mei's photos, edges crossing at 40-60 degrees),
// which scrambled the grid's coordinates and ruled out every pattern search.
//
// Used to choose which pattern to search for first, and as the board itself where the corner
// finders fail (GridFromJunctions); the finders and the whole-board and homography checks decide.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace omni::detectors {

struct GridExtent {
  int a = 0, b = 0;   // extents along the two grid directions (0: no grid)
  int count = 0;      // X-junctions in the grid
  cv::Rect box;       // their bounding box (view pixels)
  std::vector<cv::Point2f> points;  // the grid's X-junctions (view pixels)
  std::vector<cv::Point> coords;    // their grid coordinates, from (0, 0) to (a - 1, b - 1)
};

// Whether the straight step from junction p to junction q runs along an edge between a dark and
// a light region (a chessboard's line): across the step's middle, a fifth of the step to either
// side, the grey levels differ by at least `min_contrast` and the middle lies between them.
// Points outside the image: false.
bool IsEdgeStep(const cv::Mat& grey, const cv::Point2f& p, const cv::Point2f& q, double min_contrast);

// The grid grown from the junction nearest the junctions' centroid, its next-nearest seeds too
// where that grid holds under half of them (at most 5 seeds; the largest grid wins). `grey`: the
// view the junctions were found in (steps must be edges, IsEdgeStep); `spacing`: the junctions'
// typical distance (Region::spacing).
GridExtent MeasureGrid(const cv::Mat& grey, const std::vector<cv::Point2f>& p, double spacing,
                       double min_contrast);

// Whether the grid's extents are within `tolerance` rows and columns of a rows x cols pattern's
// (either way round).
bool GridNearPattern(const GridExtent& grid, int rows, int cols, int tolerance);

// Whether the grid fits in a rows x cols pattern with at most `extra` rows and columns more than
// the pattern (either way round): junctions beyond the board's sides where its sheet's narrow
// white margin meets a dark background (its outer squares' corners then read as X-junctions:
// Mei's photo 1, an 8x10 grid of a 6x8 board, one junk row or column on each of two sides).
// The session's patterns are searched in such a grid (chessboard_detector.cc SearchRegion).
bool GridFitsInPattern(const GridExtent& grid, int rows, int cols, int extra);

// Rows plus columns between the grid's extents and the pattern's, the nearer way round.
int PatternDistance(const GridExtent& grid, int rows, int cols);

}  // namespace omni::detectors
