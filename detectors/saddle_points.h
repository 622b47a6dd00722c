// Saddle points (X-junctions) of a ring view and their clusters: where chessboards and Kalibr
// AprilGrids (whose tag corners are X-junctions, kalibr_detector.h) can be. Shared by the
// chessboard detector (regions to search) and the tag detector (where the Kalibr quad finder runs).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "detectors/views.h"

namespace omni::detectors {

struct SaddleOptions {
  double sigma = 1.0;           // view pixels: smoothing before the Hessian
  double min_contrast = 100;    // grey levels across a corner for a saddle point to count
  double balance = 0.5;         // |trace H| <= balance * sqrt(-det H) at a saddle point
  int min_saddles = 4;          // a cluster with fewer saddle points is not a region
};

struct Region {
  cv::Rect rect;      // in view pixels, inside the view
  cv::Rect full;      // the same before clipping to the view
  int saddles = 0;
  double spacing = 0; // median nearest-neighbour distance of its saddle points (~ square side)
  std::vector<cv::Point2f> points;  // its saddle points
};

// Saddle points of the view: local maxima of Ixy^2 - Ixx Iyy (positive where the Hessian is
// indefinite, i.e. at X-junctions) above the strength of a saddle of `min_contrast` grey levels,
// not next to the view's invalid area.
std::vector<cv::Point2f> SaddlePoints(const RingView& view, const SaddleOptions& options);

// Groups saddle points into candidate regions: a point links to another closer than 1.25 times
// the smaller of their 4th-nearest-neighbour distances. Each region's box has a margin of
// 2.5 spacings + 8 px beyond its outermost points.
std::vector<Region> Regions(const std::vector<cv::Point2f>& points, const cv::Size& size,
                            const SaddleOptions& options);

}  // namespace omni::detectors
