// detectors/common/board_modulation.h against a drawn chessboard blurred by OpenCV (an
// independent oracle: the blurred image's max - min in the board's middle over the sharp one's),
// and DetectorEvaluation's readable count on a truth whose squares the blur flattens.
#include "detectors/common/board_modulation.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "detectors/detector_evaluation.h"

namespace omni::detectors {
namespace {

// Drawn at 8x the pixel scale (squares of whole drawn pixels: s1, s2 multiples of 1/8) so that
// every square is the same; blurred there.
double DrawnModulation(double s1, double s2, double sigma) {
  const int k = 8, n = 1024;
  cv::Mat board(n, n, CV_32F);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const int cx = static_cast<int>(std::floor(x / (k * s1))), cy = static_cast<int>(std::floor(y / (k * s2)));
      board.at<float>(y, x) = ((cx + cy) % 2 == 0) ? 1.0 : -1.0;
    }
  }
  cv::Mat blurred;
  cv::GaussianBlur(board, blurred, cv::Size(0, 0), k * sigma, k * sigma, cv::BORDER_REFLECT);
  double lo, hi;
  cv::minMaxLoc(blurred(cv::Rect(n / 4, n / 4, n / 2, n / 2)), &lo, &hi);
  return (hi - lo) / 2;
}

TEST(BoardModulation, MatchesADrawnBlurredBoard) {
  struct Case { double s1, s2, sigma; };
  for (const Case& c : {Case{7, 7, 2.6}, Case{5.625, 5.625, 2.6}, Case{3.75, 3.75, 2.6}, Case{12, 6, 1.8},
                        Case{20, 20, 1.0}}) {
    const double drawn = DrawnModulation(c.s1, c.s2, c.sigma);
    EXPECT_NEAR(ChessboardModulation(c.s1, c.s2, c.sigma), drawn, 0.01 * drawn + 2e-3)
        << c.s1 << " x " << c.s2 << " px squares, sigma " << c.sigma;
  }
  EXPECT_EQ(ChessboardModulation(5, 5, 0), 1.0);
}

TEST(BoardModulation, ReadableCountLeavesOutFlattenedSquares) {
  TargetSpec board;
  board.type = TargetType::kChessboard;
  board.rows = 2;
  board.cols = 3;
  // One 2x3 board in each ring: 8 px squares in ring 1, 3 px in ring 2.
  std::vector<TruthCorner> truth(6);
  for (int i = 0; i < 6; ++i) {
    truth[i].id = i;
    truth[i].point_in_cam = Eigen::Vector3d(750, 0, 100);
    truth[i].pixel[0] = Eigen::Vector2d(100 + 8 * (i % 3), 50 + 8 * (i / 3));
    truth[i].pixel[1] = Eigen::Vector2d(300 + 3 * (i % 3), 50 + 3 * (i / 3));
  }
  ImageObservations det;  // nothing found
  Readability readability;
  readability.blur_sigma_px = {1.0, 2.6};
  DetectorEvaluation evaluation({board}, readability);
  const std::vector<std::string> lines = evaluation.AddImage("0001", det, {}, truth);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "0001: missed: target 0 ring 1 at 0.75 m: 0 of 6 visible corners found");
  EXPECT_EQ(lines[1], "0001: missed: target 0 ring 2 at 0.75 m: 0 of 6 visible corners found (0 readable)");
  const std::string tables = evaluation.Tables();
  EXPECT_NE(tables.find("1      all               6        6        0     0.0%        0"),
            std::string::npos) << tables;
  EXPECT_NE(tables.find("2      all               6        0        0     0.0%        0"),
            std::string::npos) << tables;
}

}  // namespace
}  // namespace omni::detectors
