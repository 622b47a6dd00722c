// A trace of the chessboard detector's decisions, for finding out why a board on a real photo is
// lost: with OMNI_CHESSBOARD_TRACE set, one line per view, region, search and refusal goes to
// stderr; with OMNI_CHESSBOARD_TRACE=DIR (an existing folder) each view is also written there as
// DIR/view_<image>_<view>.png with its saddle points (red), X-junctions (green) and regions.
// Off (no cost beyond one getenv per image) when the variable is unset.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace omni::detectors::trace {

bool On();
// printf-style line to stderr, prefixed "chessboard: ", when On().
void Line(const char* format, ...) __attribute__((format(printf, 1, 2)));
// Writes the view with its saddle points, junctions and region boxes when a folder was given.
void View(int view_index, const cv::Mat& image, const std::vector<cv::Point2f>& saddles,
          const std::vector<cv::Rect>& regions);
// Marks the X-junctions found in a region of the current image's view (drawn by View).
void Junctions(int view_index, const std::vector<cv::Point2f>& junctions);
// Labels a region's grid points with their grid coordinates (drawn by View).
void Grid(int view_index, const std::vector<cv::Point2f>& points, const std::vector<cv::Point>& coords);
// Called once per image before its views are traced: numbers the images.
void NextImage();

}  // namespace omni::detectors::trace
