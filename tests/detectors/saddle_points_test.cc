// Regions (saddle_points.h): the saddle points of one board form one region at any resolution.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "detectors/common/saddle_points.h"

namespace omni::detectors {
namespace {

// A rows x cols grid of junctions `spacing` px apart from `origin`, slightly rotated (views are
// not axis-aligned with boards).
void AddGrid(int rows, int cols, double spacing, cv::Point2f origin, std::vector<cv::Point2f>* points) {
  const double c = std::cos(0.2), s = std::sin(0.2);
  for (int r = 0; r < rows; ++r) {
    for (int k = 0; k < cols; ++k) {
      points->emplace_back(origin.x + spacing * (c * k - s * r), origin.y + spacing * (s * k + c * r));
    }
  }
}

// A 35 mm board at 0.41 m in a 5 MP image's views (590 px/rad): squares ~55-60 view px. The
// links were searched within 48 px (a 1280x960 image's scale) and the board fell apart.
TEST(SaddleRegions, ANearBoardAtFiveMegapixelsIsOneRegion) {
  std::vector<cv::Point2f> points;
  AddGrid(5, 6, 58, {300, 100}, &points);
  const std::vector<Region> regions = Regions(points, {1188, 470}, SaddleOptions{}, 590);
  ASSERT_EQ(regions.size(), 1u);
  EXPECT_EQ(regions[0].saddles, 30);
  EXPECT_NEAR(regions[0].spacing, 58, 0.5);
}

// At a 1280x960 image's scale (293 px/rad) two boards 3 squares apart stay two regions and a
// far board's 12 px grid is one.
TEST(SaddleRegions, BoardsApartStayApartAtTheLowResolutionScale) {
  std::vector<cv::Point2f> points;
  AddGrid(5, 6, 30, {60, 60}, &points);
  AddGrid(5, 6, 30, {60 + 8 * 30, 60}, &points);
  AddGrid(3, 8, 12, {60, 300}, &points);
  const std::vector<Region> regions = Regions(points, {588, 494}, SaddleOptions{}, 293);
  ASSERT_EQ(regions.size(), 3u);
  for (const Region& r : regions) EXPECT_TRUE(r.saddles == 30 || r.saddles == 24) << r.saddles;
}

// A 5x6-corner board of 6 px squares (a 35 mm board at ~2 m in the webcam preset's outer ring at
// 1.2 MP) drawn at 8x, with a white margin, blurred by 1.8 px (that ring's measured blur), in a
// view whose map is the identity. The chessboard detector's saddle options merge saddle points
// within 3 blurred sigmas (6.2 px here), which took one of every two neighbouring junctions;
// neighbours' Ixy signs differ, and every junction is kept.
TEST(SaddlePoints, SmallBlurredSquaresKeepEveryJunction) {
  const int k = 8, width = 120, height = 100;
  const double side = 6, x0 = 31.3, y0 = 27.6;  // the first inner corner
  cv::Mat fine(height * k, width * k, CV_32F, cv::Scalar(220));
  for (int y = 0; y < fine.rows; ++y) {
    for (int x = 0; x < fine.cols; ++x) {
      const double u = (x + 0.5) / k, v = (y + 0.5) / k;
      const int c = static_cast<int>(std::floor((u - x0) / side)) + 1;  // 0..6 squares across
      const int r = static_cast<int>(std::floor((v - y0) / side)) + 1;  // 0..5 down
      if (c < 0 || c > 6 || r < 0 || r > 5) continue;
      fine.at<float>(y, x) = (r + c) % 2 == 0 ? 30.f : 220.f;
    }
  }
  cv::Mat image;
  cv::resize(fine, image, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 1.8);
  RingView view;
  view.width = width;
  view.height = height;
  image.convertTo(view.image, CV_8U);
  view.map_x.create(image.size(), CV_32F);
  view.map_y.create(image.size(), CV_32F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      view.map_x.at<float>(y, x) = static_cast<float>(x);
      view.map_y.at<float>(y, x) = static_cast<float>(y);
    }
  }
  view.blur_sigma = 1.8;
  SaddleOptions options;  // as ChessboardOptions sets them
  options.min_contrast = 125;
  options.balance = 1.5;
  options.merge_sigmas = 3;
  const std::vector<cv::Point2f> points = SaddlePoints(view, options);
  int found = 0;
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 6; ++c) {
      const cv::Point2f junction(static_cast<float>(x0 + c * side), static_cast<float>(y0 + r * side));
      for (const cv::Point2f& p : points) {
        if (cv::norm(p - junction) < 1.0) {
          ++found;
          break;
        }
      }
    }
  }
  EXPECT_EQ(found, 30) << points.size() << " saddle points";
}

}  // namespace
}  // namespace omni::detectors
