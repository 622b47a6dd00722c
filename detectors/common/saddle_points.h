// Saddle points (X-junctions) of a ring view and their clusters: where chessboards and Kalibr
// AprilGrids (whose tag corners are X-junctions, kalibr_detector.h) can be. Shared by the
// chessboard detector (regions to search) and the tag detector (where the Kalibr quad finder runs).
//
// Pixel scales: view pixels throughout (views.h): 1 view px of smoothing before the Hessian, a
// junction of at least min_contrast grey levels at the view's own measured blur
// (RingView::blur_sigma), clusters searched within ~9.4 degrees of the view (at least 48 px).
// Failure modes: a junction of lower contrast or blurred well beyond the ring's sharpest edges
// gives no saddle point, so its target gets no region; textured scenery gives saddle points too,
// and forms a region wherever min_saddles of them cluster: the detectors that search the regions
// decide what is a target.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/common/views.h"

namespace omni::detectors {

struct SaddleOptions {
  double sigma = 1.0;           // view pixels: smoothing before the Hessian
  // Grey levels across a corner for a saddle point to count, at the view's own blur
  // (ViewBlurSigma): a blurred X-junction's response falls as 1 / (sigma^2 + blur^2)^2, and the
  // inner ring's views (upsampled ~1.7x) of a defocused, demosaiced camera image are 2-2.5 view
  // px blurred against ~0.9 in the outer ring of a clean render.
  double min_contrast = 125;
  // With relative_contrast > 0, a saddle point of a dimmer junction counts too: it needs
  // relative_contrast times the range of grey levels around it (the junction's own contrast,
  // read over the blurred junction's extent), if that is less than min_contrast, and never less
  // than min_contrast_floor (noise). A board in shade, or one whose light is compressed by the
  // sRGB-to-linear step (Mei's paracatadioptric photos: squares 3..127 in linear light, every
  // junction ~80 grey levels) then still gives its X-junctions. 0: min_contrast alone.
  double relative_contrast = 0;
  double min_contrast_floor = 30;
  // |trace H| <= balance * sqrt(-det H) at a saddle point. Two straight edges crossing at an
  // angle phi give |trace| / sqrt(-det) = 2 |cot phi|: 0.5 takes junctions within 76-104
  // degrees, 1.5 within 53-127 (a board slanted 60 degrees about its diagonal).
  double balance = 0.5;
  // Saddle points nearer each other than this many blurred sigmas (sqrt(sigma^2 + blur^2)) are
  // one junction: the strongest is kept (0: all local maxima kept). An oblique junction's
  // response peaks twice.
  double merge_sigmas = 0;
  int min_saddles = 4;          // a cluster with fewer saddle points is not a region

  // Empty if the options are usable, else "<field>: expected ...".
  std::string Check() const;
};

struct Region {
  cv::Rect rect;      // in view pixels, inside the view
  cv::Rect full;      // the same before clipping to the view
  int saddles = 0;
  double spacing = 0; // median nearest-neighbour distance of its saddle points (~ square side)
  std::vector<cv::Point2f> points;  // its saddle points
};

// Saddle points of the view: local maxima of Ixy^2 - Ixx Iyy (positive where the Hessian is
// indefinite, i.e. at X-junctions) above the strength of a saddle of `min_contrast` grey levels
// at the view's blur (RingView::blur_sigma), not next to the view's invalid area. Kept in
// view.saddle_cache: asked again with the same options for the same image, returns that.
std::vector<cv::Point2f> SaddlePoints(const RingView& view, const SaddleOptions& options);



// Groups saddle points into candidate regions: a point links to another closer than 1.25 times
// the smaller of their 4th-nearest-neighbour distances, searched within ~9.4 degrees of a view
// of `view_f` pixels per radian (at least 48 px). Each region's box has a margin of 2.5 spacings
// + 8 px beyond its outermost points.
std::vector<Region> Regions(const std::vector<cv::Point2f>& points, const cv::Size& size,
                            const SaddleOptions& options, double view_f);

}  // namespace omni::detectors
