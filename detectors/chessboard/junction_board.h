// A region's X-junctions as a board (chessboard_detector.cc): the circle test that tells an
// X-junction from a square's corner, and the junction grid taken as the board where the corner
// finders fail or a ring boundary cuts the board.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/chessboard/junction_grid.h"
#include "detectors/common/views.h"

namespace omni::detectors {

// Whether the view shows an X-junction (two dark and two bright sectors alternating) at `p`,
// read on a circle of `radius` pixels; nullopt if part of the circle is outside the `trusted`
// pixels (RingPixels) or the view (the dark invalid area and the rim would add sectors). The Hessian saddle test cannot tell this from
// the corner of a single square (an L-corner has the same balanced Hessian at its tip), the
// circle can: an L-corner has one dark sector, an X-junction two.
// With `point_symmetric`, the two dark sectors must also face each other: two straight lines
// crossing at p make opposite sectors point-symmetric, so each sample must match the one
// opposite (all but kMaxAsymmetric of the 12 pairs: the samples on the blurred edges). An
// L-corner whose circle reaches another edge (a narrow white margin and the dark frame or
// shadow beyond it: Mei's photos, where it refused whole boards) also changes 4 times, but not
// symmetrically.
std::optional<bool> IsXJunction(const RingView& view, const cv::Mat& trusted, const cv::Point2f& p,
                                double radius, double min_contrast, bool point_symmetric = false);

// IsXJunction on a circle of 0.35 squares; where that circle reaches the ring's dark rim band
// (outside `trusted`, RingPixels), on one of 0.2 squares (2 px at least) that keeps clear of it.
// The band adds dark sectors to the larger circle: a board whose top row of squares touches
// the rim (a single mirror's render, parabolic 0012: the 3x10 board's 4 junctions nearest the
// rim) lost those junctions, and with them the whole board, as the holes were not hidden.
bool IsJunctionNearEdge(const RingView& view, const cv::Mat& in_ring, const cv::Mat& trusted,
                        const cv::Point2f& p, double spacing, double min_contrast);

// The grid's points whose X-junction circle (0.35 squares) lies in the `trusted` pixels, with
// their grid coordinates shifted to start at (0, 0) and the extents recounted. A board whose
// squares touch a ring's dark rim band grows a junk row there (its squares' corners against the
// band read as X-junctions: a single mirror's paraboloid, h47m_fresh image 0005, a 3x10 board's
// grid 10x4), which no placement in the pattern can hold; without it the grid fits.
GridExtent TrustedPart(const RingView& view, const cv::Mat& trusted, const GridExtent& grid, double spacing);

// Where a board's grid may be fit across gaps (GridFromJunctions): the view's X-junctions outside
// the grid (the part of a board beyond a post's band, which the grid's growth cannot cross) and
// the contrast an X-junction at a predicted corner must show (IsXJunction).
struct JunctionGaps {
  std::vector<cv::Point2f> loose;
  double min_contrast = 10;
};

// The junction grid as a rows x cols corner list in row-major order: the last resort where
// both OpenCV finders fail on a board the saddle detector saw (demo image 0008: a board whose
// white margin is cut by the ring's edge, lost by both finders on sharper renders), and the way
// a board cut by a ring boundary or crossed by a post of the mount still gives its visible
// corners. Grid points may be missing only where the view hides them: their place, predicted by
// the homography of the corners found, must be too near the ring's edge or a post's band for
// the X-junction test (both are outside the view's map: RigModel's projection blocks a path
// through a post; `trusted`, RingPixels with the edge margin, keeps that margin from both). A
// missing point that the view shows whole means an occlusion or a miss, and the placement is
// refused. A point whose circle reaches the ring's dark rim band is hidden, as the junction
// test could not have seen it there (parabolic 0012: a 3x10 board's 4 junctions on the rim
// band's edge, inside the ring as modelled, refused the board).
// Without `gaps`: the grid's extents may fall short of the pattern's by one row or column,
// hidden along one side, and it must hold three quarters of the pattern (or all but its longest
// row or column). With `gaps`: any number of rows or columns may be missing, on any side or as
// a band across the middle: the grid found is placed every way inside the pattern; where a
// placement predicts a corner at one of the loose junctions that junction is taken and the
// homography refitted, and where the view shows an X-junction at a prediction (point-symmetric,
// gaps->min_contrast: a corner the saddle detector missed in a blurred ring) the prediction is
// taken; half the pattern must be in plain sight.
// Either way exactly one placement must hold: where several do (a grid that either side could
// extend) the ids are ambiguous and the board is refused. *placements (may be null): how many
// held (the caller refuses a grid that another of the session's patterns holds too). Missing points get the prediction
// and `filled` marks them: they help check and orient the board and are never reported (their
// refinement windows would take in the ring's edge or the post). Ids are left to Orient and the
// same whole-board and homography checks as the finders' grids.
bool GridFromJunctions(const RingView& view, const cv::Mat& trusted, const GridExtent& grid, double spacing, int rows,
                       int cols, const JunctionGaps* gaps, std::vector<cv::Point2f>* corners,
                       std::vector<bool>* filled, int* placements = nullptr);

}  // namespace omni::detectors
