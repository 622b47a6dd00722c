// Kalibr AprilGrid (`kalibr_aprilgrid`) tags in an un-mirrored ring view (views.h), and their
// corners refined in the raw image.
//
// Why off-the-shelf detectors fail on these grids: kalibr_create_target_pdf puts a black square at
// each tag's four diagonal corners (model/target.h), touching the tag's black border exactly at
// the corner. After the views' resampling blur the tag and its four corner squares are ONE black
// blob, so neither libapriltag's quad finder (boundary clusters between one black and one white
// component) nor aruco's contour finder sees a four-sided outline: the only quads left are the
// empty corner squares. Here the black mask is opened by a one-pixel erosion, which breaks the
// blur-sized necks at the touching points, the tags' outlines become quads again, and we decode
// them ourselves (10 x 10 bits: 2-bit black border, tag36h11's 6 x 6 data bits, codes and bit
// positions from libapriltag's family as synthetic/tag_texture.cc prints them).
//
// The same corner squares make every tag corner an X-junction (black tag and black square in
// opposite quadrants, white gaps in the other two), i.e. a chessboard-like saddle: cornerSubPix
// converges there without bias in the raw image, under the mirrors' local affine distortion.
//
// Ids are right or absent: only exact codes (hamming 0), a dark 2-bit border, every data bit
// clearly on one side of the threshold; the caller checks the id set and the neighbours.
//
// Scale and failure modes, in short: quads are found on the view enlarged 2x, with tag sides of at
// least min_side_px (10 view px) and 25 grey levels between local black and white; a code is
// taken only with every data bit 5% of the contrast clear of the threshold (blurred views: the
// blurred pattern's best code by a margin). Tags whose erosion does not separate them from their
// corner squares (very blurred views), whose border is not dark all round, or that disagree with
// their neighbours' homography by more than 0.15 of a side give nothing.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/target.h"

namespace omni::detectors {

// Acceptance of a blurred reading (ReadTagBlurred). On the true quads of the realistic session
// (realistic camera preset, inner ring, 2-3 raw px per bit) the right code fits to 0.035 (mean,
// max 0.066 with the corners 0.8 view px off) and the next code 0.04-0.2 worse, at least 1.46x.
struct BlurredReadOptions {
  double max_residual = 0.12;  // rms misfit / contrast of the best code
  double min_margin = 0.035;   // second - residual
  double min_ratio = 1.4;      // second / residual
  double min_contrast = 20;    // grey levels
};

struct KalibrDetectorOptions {
  int upsample = 2;                 // the view is enlarged this much before thresholding
  int threshold_window_px = 9;      // local min/max window for the threshold (enlarged pixels)
  int min_contrast = 25;            // grey levels between local black and white
  int separation_px = 1;            // erosion of the black mask (enlarged pixels), first pass
  int separation_passes = 3;        // passes with separation_px, +1, +2, ...
  // Shortest tag side accepted (view pixels): a pixel-grid limit, a view pixel per bit of a
  // Kalibr tag (10 bits across), the same at any image size.
  double min_side_px = 10;
  double min_bit_margin = 0.05;     // |bit - threshold| / (white - black), each data bit
  // A quad that does not read is read once more from its corners refined as X-junctions.
  bool refine_quad_before_decode = true;
  bool refine_in_view = true;       // saddle refinement of the corners in the view
  double max_neighbour_error = 0.15;  // of a tag's corners vs its neighbours' homography / side
  // The view's blur (RingView::blur_sigma, view pixels); 0: unknown (sharp). Scales the mask's
  // threshold window and erosions, and a quad that does not read exactly is read by its blurred
  // pattern (ReadTagBlurred) when this is set.
  double blur_sigma = 0;
  bool read_blurred = true;
  BlurredReadOptions blurred;

  // Empty if the options are usable, else "<field>: expected ...": an enlargement, window or
  // pass count under 1, a side, margin or blur out of range.
  std::string Check() const;
};

// How a tag is laid out in bits (model/target.h): Kalibr 10 bits across with a 2-bit border,
// 3-bit gaps and black squares at the diagonal corners; plain tag36h11 8 bits, 1-bit border.
struct TagLayout {
  int bits = 10;
  int border = 2;
  bool corner_squares = true;
};
TagLayout KalibrTagLayout();
TagLayout PlainTagLayout();

// The printed value of cell (x, y) of tag `tag_id` (bits from the tag's top-left outer corner,
// y down): 1 white, 0 black; cells outside the tag are 1.
int TagCellValue(int tag_id, const TagLayout& layout, int x, int y);

// Reading a tag by its blurred pattern: the view sampled at every bit cell of the tag and its
// outside ring, compared with what each tag36h11 code in each rotation would give at the view's
// blur (each cell's Gaussian-weighted neighbours, the bit size from the quad), the levels fitted.
// residual: rms misfit / fitted contrast of the best code; second: the same for the next code.
struct BlurredReading {
  int tag_id = -1;
  int rotation = -1;  // the printed TL corner is quad[rotation]
  double residual = 1e9, second = 1e9;
  double contrast = 0;  // fitted white - black (grey levels)
};
// quad: the tag's outer corners (view pixels) TL, TR, BR, BL as printed up to a rotation.
// tag_id -1 when no code reads with the options' residual and margin.
BlurredReading ReadTagBlurred(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                              const TagLayout& layout, double blur_sigma,
                              const BlurredReadOptions& options = {});
// The residual (as BlurredReading::residual) of one code in one orientation: quad is TL, TR, BR,
// BL as printed. 1e9 outside the image or with no contrast.
double TagCodeResidual(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                       const TagLayout& layout, double blur_sigma, int tag_id,
                       double* contrast = nullptr);

// A Kalibr tag in a view: its absolute tag id and corners (view pixels), index k (model/target.h:
// k = 0 bottom-left, 1 bottom-right, 2 top-right, 3 top-left as printed).
struct KalibrViewTag {
  int tag_id = 0;
  Eigen::Vector2d corners[4];
};

// The black mask the tag outlines are found in: the view enlarged `upsample` times, thresholded
// between local extremes, black eroded by separation_px (CV_8U, 255 = black).
cv::Mat KalibrTagMask(const cv::Mat& view_grey, const KalibrDetectorOptions& options);

// Every tag36h11 code read exactly in a CV_8U grey view.
std::vector<KalibrViewTag> DetectKalibrTagsInView(const cv::Mat& view_grey,
                                                  const KalibrDetectorOptions& options = {});

// Plain tag36h11 tags in a blurred CV_8U view read by their blurred pattern (ReadTagBlurred):
// outlines from the view thresholded between local extremes (window 2.5 blur sigmas each side),
// quads fitted to them. For views where libapriltag's quad finder misses the tags.
std::vector<KalibrViewTag> DetectPlainTagsBlurred(const cv::Mat& view_grey, double blur_sigma,
                                                  const BlurredReadOptions& options = {});

// Neighbour check for the tags of ONE target found in one view: a homography from the target
// plane to the view fitted by RANSAC to all their corners (CornerInTarget); tags with a corner
// farther than max_neighbour_error * their side from it are removed. Needs two tags or more
// (a lone tag stays: its exact code is the only evidence).
void DropTagsInconsistentWithNeighbours(const TargetSpec& target, double max_neighbour_error,
                                        std::vector<KalibrViewTag>* tags);

// True if `corner` (grey CV_8U) looks like a Kalibr tag corner: dark at distance r into the tag
// (between the unit directions to_next and to_previous along its edges) and in the diagonally
// opposite corner square, light in the two gaps, by at least min_contrast grey levels. Rejects
// corners whose corner square or gap is cut off (ring boundary, lip, image edge).
bool IsKalibrXJunction(const cv::Mat& grey, const Eigen::Vector2d& corner,
                       const Eigen::Vector2d& to_next, const Eigen::Vector2d& to_previous, double r,
                       int min_contrast);

// Refines an X-junction (saddle) corner in a grey image (CV_8U or CV_32F) from an estimate within
// about half_window_px / 2: cv::cornerSubPix over a (2 half_window_px + 1)^2 window. False if it
// moved farther than max_shift_px or left the image.
bool RefineSaddleCorner(const cv::Mat& grey, const Eigen::Vector2d& corner, int half_window_px,
                        double max_shift_px, Eigen::Vector2d* refined);

}  // namespace omni::detectors
