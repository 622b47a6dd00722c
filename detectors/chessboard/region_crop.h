// A saddle region of a view as the crop the OpenCV corner finders search (chessboard_detector.cc).
#pragma once

#include <opencv2/core.hpp>

#include "detectors/common/views.h"

namespace omni::detectors {

// The view's pixels in `full` (a saddle region's box) as a crop for the corner finders, padded
// to the box's full size where it runs off the view and with the view's invalid pixels (outside the ring) set to the
// crop's paper white (its 90th percentile): a board whose white margin is cut by the ring's edge
// then still has separable outer squares (against black they merge, and the finders fail near
// a crop border), and the padding reads as more of the sheet's margin. Mid grey, the fill
// before, sits at both finders' binarisation level: a band of it along a crop's side (a region
// by the view's edge, the camera's own hole) made both fail on clear boards (Mei's photo 2: the
// classic and the sector finder each found the board in the crop filled white or black, neither
// in it filled at 128).
cv::Mat RegionCrop(const RingView& view, const cv::Rect& full);

}  // namespace omni::detectors
