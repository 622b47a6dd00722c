// The overlay `detect --overlay` writes per photo: what the detectors found, drawn on the photo
// so that a person can check it at a glance (docs/guide.md step 5).
//   - the ring boundaries the model predicts (cyan lines);
//   - corners as crosses coloured by ring (mirror 1 green, mirror 2 magenta); each board named
//     once per ring beside its corners ("T0 chessboard 5x6": below, else above or right of it
//     where another board's name is not), and the ids of as many corners as
//     can be read without overlapping (SpreadLabels: the inner ring's corners are 3-5 px apart,
//     one label per corner was one magenta blob);
//   - lip edge points as single yellow pixels, so that the painted band between them stays
//     visible;
//   - a legend of these colours in the top-left corner.
// The text is scaled with the image (1 at 1280 px wide) and drawn over a dark outline.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/common/ring_layout.h"
#include "model/observations.h"
#include "model/target.h"

namespace omni::apps {

// Which of `anchors` (in order of preference) get a label: each kept one at least `min_px` from
// every other kept one.
std::vector<size_t> SpreadLabels(const std::vector<cv::Point2d>& anchors, double min_px);

// The overlay of `image` (as read: grey or colour, 8 or 16 bit) as 8-bit BGR.
cv::Mat DrawOverlay(const cv::Mat& image, const detectors::RingLayout& layout,
                    const ImageObservations& detections, const std::vector<TargetSpec>& targets);

// A vertical colour bar of OpenCV colour map `colormap` in the top-right corner of `image`
// (8-bit BGR): 0 at the bottom, `max_value` at the top, both written beside it with `unit`, and
// `title` above it. Returns the bar's rectangle (the gradient only).
cv::Rect DrawColourBar(cv::Mat* image, int colormap, double max_value, const std::string& unit,
                       const std::string& title);

}  // namespace omni::apps
