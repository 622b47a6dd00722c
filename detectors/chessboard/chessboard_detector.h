// Chessboards in an omnidirectional image: found in the un-mirrored perspective views of each
// ring (views.h), mapped back to the raw image through the model and refined there.
//
// Per view: saddle points (negative Hessian determinant of the smoothed view) propose regions
// where corners cluster; the extent of a region's X-junction grid picks the rows x cols to search
// for (all of the session's distinct patterns when none matches); OpenCV's findChessboardCorners
// runs on the region's crop, findChessboardCornersSB where it fails or its grid is refused.
// Corners are mapped to raw pixels by the model's exact projection of the view ray
// (RingView::ViewToRawExact) and refined sub-pixel in the RAW image (cv::cornerSubPix with a
// window scaled to the local square size). A board must be whole (no X-junction beyond its sides)
// and its refined corners must fit the board's homography in the view (to 0.5 raw px; a grid
// with mis-ordered rows or columns is refused whole, never guessed from).
// A board found in two overlapping views is kept from the view whose centre it is nearest.
//
// Corner ids (id = row * cols + col, model/target.h) follow one rule in both rings, which is how
// synthetic places boards: seen from the rig, the target's +x (increasing col) points
// towards increasing azimuth (counter-clockwise about +z_C, the viewer's LEFT) and its +y
// (increasing row) points UP (+z_C); corner 0 is the lowest, rightmost inner corner seen from the
// rig. Among the labellings a board's symmetry allows (180 degrees; 90 degrees too for square
// boards; never a mirror image, the views are un-mirrored) the one closest to that rule is taken.
// So the two rings' views of one physical board get the same ids. A board held more than 45
// degrees away from that attitude gets rotated ids (consistently in both rings).
//
// Limits: two chessboard targets with the same rows x cols cannot be told apart (the first in
// the list is reported). A board that a ring boundary cuts, or a post of the mount crosses (the
// view's map is invalid over a post: RigModel's projection blocks the path), gives the corners
// it shows through its junction grid (GridFromJunctions): cut by one row or column along one
// side, among the finders; cut by more, on any side, or crossed by a post's band (its junctions
// in two grids, fit across the band; on a rig with posts a grid beside untrusted pixels may
// then hold under half the pattern), last, where no finder found a board in the region. The
// corners it lacks must be hidden (by the ring's edge or a post, with the edge margin), half the
// pattern must show, and where the grid fits the pattern in more than one place (or, across
// gaps, fits another of the session's patterns too) the ids are ambiguous and the board is
// refused. Hidden corners and corners whose junction circle reaches
// the edge margin (beside a post's band: ~0.35 squares + edge_margin_rad) are left out, as are
// those whose refinement window would take in the ring's edge. Boards showing less than half
// their corners are found from the other ring's view of them (guided_detection.h).
//
// Scale and failure modes, in short: OpenCV's finders need squares of several view pixels, and
// the saddle regions a contrast of saddle_min_contrast (125 grey levels across a corner at the
// view's blur); the raw refinement window is 0.55 squares (2-8 px half-width), so raw squares
// under ~3 px get a 1 px window. Boards are refused whole where the grid fails the homography test
// (0.5 raw px, 90% inliers), corners whose refinement moves them more than max(1.5 px, 0.3 squares)
// are left out, and boards showing under half their corners give nothing here (see Limits above).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/common/views.h"
#include "model/observations.h"
#include "model/rig_model.h"
#include "model/target.h"

namespace omni::detectors {

struct ChessboardOptions {
  double saddle_sigma = 1.0;       // view pixels: smoothing before the Hessian
  double saddle_min_contrast = 125; // grey levels across a corner, at the view's blur (saddle_points.h)
  // Or this fraction of the junction's own contrast, not under the floor, where a circle about
  // it shows a clear X-junction (SaddleOptions): a board in shade (Mei's photos in linear light:
  // ~80 grey levels per junction) gives its junctions too. 0 (off) by default: on the folded
  // rig's rendered rooms the low-contrast junctions of the room's textures joined the boards'
  // regions (detector_eval_scene: chessboard recall 100% / 100% -> 56% / 11%); DetectorContext
  // turns it on for single rigs, whose boards are held in the shade below the mirror.
  double saddle_relative_contrast = 0;
  double saddle_contrast_floor = 10;
  // |trace H| <= balance * sqrt(-det H) at a saddle point: 1.5 takes junctions whose edges
  // cross at 53-127 degrees (a board slanted 60 degrees about its diagonal; 0.5 took 76-104 and
  // lost every junction of Mei's boards held flat below the mirror).
  double saddle_balance = 1.5;
  double saddle_merge_sigmas = 3;  // one junction's twin peaks merged (SaddleOptions::merge_sigmas)
  int min_saddles = 4;             // a region with fewer saddle points is not tried
  int max_boards_per_region = 4;
  // The whole-board test reads no pixel nearer than this to a ring's edge (its dark rim band,
  // chessboard_detector.cc RingPixels); radians of view angle.
  double edge_margin_rad = 0.03;
  bool sector_fallback = true;     // findChessboardCornersSB where findChessboardCorners fails
  bool refine_in_raw = true;       // cornerSubPix in the raw image (else: the view's corner mapped)
  // After the raw refinement: a corner whose window takes in more than its own four squares is
  // refined again in a window that leaves the rest out, or dropped where that window's half
  // would be under min_clean_half (corner_refine.h KeepWindowsOnTheirSquares).
  bool clean_windows = true;
  int min_clean_half = 2;
  // A foreign edge must be this fraction of the board's own edges' slope (corner_refine.h
  // CleanHalfWindow): 0.5 catches the folded rig's painted lips; DetectorContext sets 0.7 for
  // single rigs (no lips; their rim is black; boards' sheen in linear light let through).
  double foreign_edge_slope = 0.5;
  // A board the views find less than whole searched in the photo itself (raw_board.h);
  // DetectorContext sets it for single rigs.
  bool search_photo = false;
  // After the raw refinement: subtract cornerSubPix's bias on the curved images of the board's
  // lines, predicted from the refined neighbours (detectors/common/corner_refine.h).
  bool remove_curvature_bias = true;
  // After the raw refinement: each corner fitted by a blurred X-junction model
  // (corner_refine.h FitBoardJunctions; the curvature correction where it cannot be), in a
  // window of this many squares (half-width); where the ring's measured blur exceeds
  // kBlurredBoardFraction of the squares, fitted again as the blurred board, as guided
  // detection does (board_junction_fit.h).
  bool fit_junctions = true;
  double junction_window_squares = 0.55;
  // Raw refinement moving a corner further than the larger of these rejects it.
  double max_refine_shift_px = 1.5;
  double max_refine_shift_squares = 0.3;  // of the local square side in the raw image
  // Grid check (GridFitsBoard): a refined corner further than this from the homography fitted
  // to the board's corners in the view (mapped to raw) is an outlier; a board with fewer inliers than the
  // fraction is refused whole (a mis-ordered grid), else its outliers are dropped.
  double max_grid_ransac_squares = 0.15;  // RANSAC tolerance in the view (of a square)
  double max_grid_residual_px = 0.5;      // the test, in raw pixels
  double min_grid_inlier_fraction = 0.9;
  // The grid check against the homography plus a quadratic in the board's coordinates (fitted
  // to the corners): a start model that is itself a few pixels off (a single mirror's, from its
  // rim alone: 1-3 raw px across a board on Mei's photos, DetectorContext sets it for single
  // rigs) bends the board's image in the view smoothly; a mis-ordered corner stays off.
  bool smooth_grid_correction = false;
  // With the smooth correction, a corner passes the test within this fraction of its raw square
  // side too (when that is more than max_grid_residual_px): the start model's error grows with
  // the board's image (Mei's photo 8, squares of ~30 raw px near the rim: residuals of 1-2 px
  // after the cubic correction at corners within 0.9 px of OpenCV's).
  double max_grid_residual_squares = 0.05;

  // Empty if the options are usable, else "<field>: expected ...": a smoothing, window, shift
  // or tolerance <= 0, a count under 1, a fraction outside [0, 1] (foreign_edge_slope: (0, 1]).
  std::string Check() const;
};

// One detected board (before flattening into observations).
struct BoardDetection {
  int target = 0;                   // index into the target list
  Mirror mirror = Mirror::kOne;
  int view = 0;                     // index into the views
  std::vector<int> ids;
  std::vector<Eigen::Vector2d> view_pixels, raw_pixels;
  double off_centre = 0;            // distance of the board's centre from the view's centre (px)
};

// A board's corners refined in the raw image as every chessboard's are (raw[id]: the start, from
// a view or a finder; nullopt: hidden): cv::cornerSubPix in a window of 0.55 squares
// (corner_window.h), a move beyond max(max_refine_shift_px, max_refine_shift_squares) refused,
// windows kept on their own four squares (blur_px: the image's blur there), the blurred
// junction fitted (FitBoardJunctions). refined[id]: nullopt where refused.
struct RawRefinement {
  std::vector<std::optional<Eigen::Vector2d>> refined;
  int refused_refine = 0, refused_shift = 0, refused_window = 0;
};
RawRefinement RefineBoardInRaw(const cv::Mat& raw_grey, const RigModel& model, const TargetSpec& spec,
                               const std::vector<std::optional<Eigen::Vector2d>>& raw,
                               double blur_px, const ChessboardOptions& options);

// Of boards found in one image, drops a placement (the smaller first) that
// repeats ids of larger ones of its target in its ring beyond the number of sheets printed with
// the pattern (a sheet shows each corner once per ring). Parts of one board with no id in common
// stay. A dropped placement with at least half its target's corners is another copy of the
// sheet (several identical sheets in one photo): its target index is appended to *repeated.
std::vector<BoardDetection> DropRepeatedPlacements(std::vector<BoardDetection> boards,
                                                   const std::vector<TargetSpec>& targets,
                                                   std::vector<int>* repeated = nullptr);

// Several identical sheets listed as targets (one chessboard pattern, rows x cols, listed k
// times): every copy found carries the first such target's index. Gives the copies in one
// photo one target each, the same in both rings: copies are paired across the rings by the
// azimuth of their corners' rays (model.Unproject) and numbered in order of azimuth. Across
// photos the numbering need not follow one physical sheet (each placement is posed on its own).
void SpreadCopiesOverTheirTargets(const RigModel& model, const std::vector<TargetSpec>& targets,
                                  std::vector<BoardDetection>* boards);

// Chessboards in one image. `views` must have been rendered from this image (RenderViews);
// `raw_grey` is the raw image as CV_8U grey. Targets that are not chessboards are ignored; the
// target index of an observation is its index in `targets`. *repeated (may be null): as
// DropRepeatedPlacements, the targets of which another copy was found and left out.
std::vector<BoardDetection> DetectChessboardBoards(const cv::Mat& raw_grey,
                                                   const std::vector<RingView>& views,
                                                   const RigModel& model,
                                                   const std::vector<TargetSpec>& targets,
                                                   const ChessboardOptions& options = {},
                                                   std::vector<int>* repeated = nullptr);

std::vector<CornerObservation> DetectChessboards(const cv::Mat& raw_grey,
                                                     const std::vector<RingView>& views,
                                                     const RigModel& model,
                                                     const std::vector<TargetSpec>& targets,
                                                     const ChessboardOptions& options = {},
                                                     std::vector<int>* repeated = nullptr);

}  // namespace omni::detectors
