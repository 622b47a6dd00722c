// Regions (saddle_points.h): the saddle points of one board form one region at any resolution.
#include <gtest/gtest.h>

#include <vector>

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

}  // namespace
}  // namespace omni::detectors
