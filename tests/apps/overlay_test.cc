// The detection overlay (apps/overlay.h): ids spread so that they can be read, a legend of the
// colours, lip edge points drawn as single pixels (the band between them stays visible).
#include "apps/overlay.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace omni::apps {
namespace {

// An inner-ring board at 6x zoom was one magenta blob: 48 corners 4 px apart.
std::vector<cv::Point2d> DenseBoard() {
  std::vector<cv::Point2d> corners;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 8; ++c) corners.emplace_back(600 + 4.0 * c, 400 + 4.0 * r);
  }
  return corners;
}

TEST(Overlay, LabelsAreSpreadApart) {
  const std::vector<cv::Point2d> corners = DenseBoard();
  const std::vector<size_t> kept = SpreadLabels(corners, 24);
  ASSERT_FALSE(kept.empty());
  EXPECT_EQ(kept.front(), 0u);
  EXPECT_LT(kept.size(), 6u);
  for (size_t a = 0; a < kept.size(); ++a) {
    for (size_t b = a + 1; b < kept.size(); ++b) {
      EXPECT_GE(cv::norm(corners[kept[a]] - corners[kept[b]]), 24.0);
    }
  }
  // Corners far apart (the outer ring's large boards) all keep their ids.
  std::vector<cv::Point2d> sparse;
  for (int k = 0; k < 10; ++k) sparse.emplace_back(30.0 * k, 0);
  EXPECT_EQ(SpreadLabels(sparse, 24).size(), 10u);
}

int Count(const cv::Mat& image, const cv::Rect& area, const cv::Vec3b& colour) {
  int n = 0;
  for (int v = area.y; v < area.y + area.height; ++v) {
    for (int u = area.x; u < area.x + area.width; ++u) n += image.at<cv::Vec3b>(v, u) == colour;
  }
  return n;
}

TEST(Overlay, LegendAndSinglePixelLipPoints) {
  const cv::Mat photo(960, 1280, CV_8UC3, cv::Scalar(0, 0, 200));  // a red band everywhere
  ImageObservations det;
  LipEdgeObservation lip;
  for (int k = 0; k < 200; ++k) {
    const double phi = 2 * M_PI * k / 200;
    lip.points.emplace_back(640 + 300 * std::cos(phi), 480 + 300 * std::sin(phi));
  }
  det.lips.push_back(lip);
  for (const cv::Point2d& p : DenseBoard()) {
    CornerObservation c;
    c.target = 0;
    c.id = static_cast<int>(det.corners.size());
    c.mirror = Mirror::kTwo;
    c.pixel = Eigen::Vector2d(p.x, p.y);
    det.corners.push_back(c);
  }
  const cv::Mat out = DrawOverlay(photo, detectors::RingLayout(), det, {ChessboardSpec(6, 8, 40)});
  ASSERT_EQ(out.type(), CV_8UC3);
  // The lip: at most one yellow pixel per point (a filled circle each covered the band).
  const cv::Rect band(640 - 310, 480 - 310, 620, 620);
  const int yellow = Count(out, band, cv::Vec3b(0, 255, 255));
  EXPECT_GT(yellow, 150);
  EXPECT_LE(yellow, 200);
  // The legend, top left: ring 1's green, ring 2's magenta, the lip's yellow and the boundaries'
  // cyan all drawn there.
  const cv::Rect legend(0, 0, 330, 90);
  for (const cv::Vec3b colour : {cv::Vec3b(0, 220, 0), cv::Vec3b(255, 0, 255), cv::Vec3b(0, 255, 255),
                                 cv::Vec3b(255, 255, 0)}) {
    EXPECT_GT(Count(out, legend, colour), 3) << colour;
  }
}

// Two boards' names that would fall on one another (a board seen at the same place in both
// rings' corners): the second goes above its board.
TEST(Overlay, BoardNamesDoNotOverlap) {
  const cv::Mat photo(960, 1280, CV_8UC3, cv::Scalar(0, 0, 0));
  ImageObservations det;
  for (const Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    for (const cv::Point2d& p : DenseBoard()) {
      CornerObservation c;
      c.target = 0;
      c.id = 0;
      c.mirror = mirror;
      c.pixel = Eigen::Vector2d(p.x, p.y);
      det.corners.push_back(c);
    }
  }
  const cv::Mat out = DrawOverlay(photo, detectors::RingLayout(), det, {ChessboardSpec(6, 8, 40)});
  // The board spans rows 400-420; ring 1's name below it, ring 2's above.
  const auto count = [&](int v0, int v1, bool magenta) {
    int n = 0;
    for (int v = v0; v < v1; ++v) {
      for (int u = 590; u < 900; ++u) {
        const cv::Vec3b c = out.at<cv::Vec3b>(v, u);
        n += magenta ? (c[0] > 180 && c[2] > 180 && c[1] < 80) : (c[1] > 180 && c[0] < 80 && c[2] < 80);
      }
    }
    return n;
  };
  EXPECT_GT(count(424, 442, false), 20);
  EXPECT_LT(count(424, 442, true), 5);
  EXPECT_GT(count(370, 396, true), 20);
}

// The exports' residual map carries its colour bar: blue at the bottom (0), red at the top.
TEST(Overlay, ColourBarRunsFromBlueAtZeroToRedAtTheTop) {
  cv::Mat image(960, 1280, CV_8UC3, cv::Scalar(0, 0, 0));
  const cv::Rect bar = DrawColourBar(&image, cv::COLORMAP_JET, 0.125, "px", "residual");
  ASSERT_TRUE(cv::Rect(0, 0, 1280, 960).contains(bar.br() - cv::Point(1, 1)));
  EXPECT_GT(bar.x, 1280 / 2);
  EXPECT_LT(bar.y, 960 / 4);
  const cv::Vec3b top = image.at<cv::Vec3b>(bar.y + 2, bar.x + bar.width / 2);
  const cv::Vec3b bottom = image.at<cv::Vec3b>(bar.y + bar.height - 3, bar.x + bar.width / 2);
  EXPECT_GT(top[2], 100);     // red
  EXPECT_LT(top[0], 60);
  EXPECT_GT(bottom[0], 100);  // blue
  EXPECT_LT(bottom[2], 60);
  // Its labels are drawn left of it.
  int lit = 0;
  for (int v = bar.y; v < bar.y + bar.height; ++v) {
    for (int u = bar.x - 80; u < bar.x - 2; ++u) lit += image.at<cv::Vec3b>(v, u)[1] > 128;
  }
  EXPECT_GT(lit, 20);
}

}  // namespace
}  // namespace omni::apps
