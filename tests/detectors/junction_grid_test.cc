// The junction grid on a drawn chessboard (no render): a board seen obliquely, as Mei's
// paracatadioptric photos show their boards held flat below the mirror.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "detectors/chessboard/junction_grid.h"

namespace omni::detectors {
namespace {

// A rows x cols inner-corner chessboard drawn through the affine map x = o + c u + r v (u, v: a
// square's two sides in px), squares `dark` and `light`, blurred by 1 px; the inner corners
// are returned.
cv::Mat DrawBoard(int rows, int cols, cv::Point2f o, cv::Point2f u, cv::Point2f v, int dark, int light,
                  std::vector<cv::Point2f>* corners) {
  cv::Mat image(300, 400, CV_8U, cv::Scalar(light));
  for (int r = -1; r < rows; ++r) {
    for (int c = -1; c < cols; ++c) {
      if ((r + c) % 2 != 0) continue;
      const cv::Point2f a = o + static_cast<float>(c) * u + static_cast<float>(r) * v;
      std::vector<cv::Point> quad{a, a + u, a + u + v, a + v};
      cv::fillConvexPoly(image, quad, cv::Scalar(dark), cv::LINE_AA);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 1.0);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) corners->push_back(o + static_cast<float>(c) * u + static_cast<float>(r) * v);
  }
  return image;
}

// A square's side is an edge between dark and light; its diagonal crosses one square's plain
// inside. On a board whose diagonal is shorter than its sides (edges crossing at 50 degrees) the
// grid grows along the sides: rows x cols extents, not a diagonal lattice.
TEST(JunctionGrid, StepsRunAlongEdgesNotDiagonals) {
  std::vector<cv::Point2f> corners;
  const cv::Point2f u(30, 0), v(22, 23);  // |u - v| = 23.1 < |u| = 30 < |v| = 31.8
  const cv::Mat image = DrawBoard(4, 6, {40, 40}, u, v, 20, 230, &corners);
  const cv::Point2f c0 = corners[0];
  EXPECT_TRUE(IsEdgeStep(image, c0, c0 + u, 10));
  EXPECT_TRUE(IsEdgeStep(image, c0, c0 + v, 10));
  EXPECT_FALSE(IsEdgeStep(image, c0 + u, c0 + v, 10));  // the short diagonal
  const GridExtent grid = MeasureGrid(image, corners, 23, 10);
  EXPECT_EQ(grid.count, 24);
  EXPECT_TRUE((grid.a == 6 && grid.b == 4) || (grid.a == 4 && grid.b == 6)) << grid.a << "x" << grid.b;
}

}  // namespace
}  // namespace omni::detectors
