// The printable targets' PNGs (print/target_sheet.h) are detected by the reference libraries and
// by our own tag readers at every id, at the size that was asked: chessboards by OpenCV's
// findChessboardCornersSB, plain tag36h11 grids by libapriltag, Kalibr AprilGrids (2-bit border)
// by OpenCV's aruco with markerBorderBits = 2, tag grids also by detectors/apriltag/kalibr_detector.h.
#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <gtest/gtest.h>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/apriltag/kalibr_detector.h"
#include "print/target_sheet.h"

namespace omni {
namespace {

constexpr double kDpi = 200;
constexpr double kPxPerMm = kDpi / 25.4;

cv::Mat PrintedGrey(const TargetSpec& target, print::TargetPage* page) {
  print::Paper a4;
  EXPECT_TRUE(print::PaperByName("A4", &a4));
  *page = print::LayoutTargetPage(target, a4);
  const std::string png = print::PngBytes(*page, kDpi);
  cv::Mat grey = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(grey.cols, std::lround(page->width_mm * kPxPerMm));
  EXPECT_EQ(grey.rows, std::lround(page->height_mm * kPxPerMm));
  return grey;
}

std::set<int> Ids(const TargetSpec& t) {
  std::set<int> ids;
  for (int k = 0; k < t.rows * t.cols; ++k) ids.insert(t.first_id + k);
  return ids;
}

// The side (px) of a tag from its four corners.
double Side(const std::vector<cv::Point2d>& q) {
  double s = 0;
  for (int k = 0; k < 4; ++k) s += cv::norm(q[k] - q[(k + 1) % 4]);
  return s / 4;
}

TEST(PrintedTarget, ChessboardFoundByOpenCvAtItsSquareSize) {
  TargetSpec t = ChessboardSpec(6, 8, 20.0);
  print::TargetPage page;
  const cv::Mat grey = PrintedGrey(t, &page);
  std::vector<cv::Point2f> corners;
  ASSERT_TRUE(cv::findChessboardCornersSB(grey, cv::Size(t.cols, t.rows), corners));
  ASSERT_EQ(corners.size(), 48u);
  // Neighbouring corners one square apart (the PNG's pixels at 200 dpi).
  double worst = 0;
  for (int r = 0; r < t.rows; ++r) {
    for (int c = 0; c + 1 < t.cols; ++c) {
      const double d = cv::norm(corners[r * t.cols + c + 1] - corners[r * t.cols + c]);
      worst = std::max(worst, std::abs(d / kPxPerMm - 20.0));
    }
  }
  EXPECT_LT(worst, 0.05) << "mm";
}

TEST(PrintedTarget, PlainTagGridFoundByLibapriltagAndOursAtEveryId) {
  TargetSpec t;
  t.type = TargetType::kAprilTagGrid;
  t.rows = 4;
  t.cols = 5;
  t.tag_size_mm = 25;
  t.spacing = 0.3;
  t.first_id = 10;
  print::TargetPage page;
  const cv::Mat grey = PrintedGrey(t, &page);

  apriltag_family_t* family = tag36h11_create();
  apriltag_detector_t* detector = apriltag_detector_create();
  apriltag_detector_add_family(detector, family);
  image_u8_t image = {grey.cols, grey.rows, static_cast<int32_t>(grey.step), grey.data};
  zarray_t* found = apriltag_detector_detect(detector, &image);
  std::set<int> ids;
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* d;
    zarray_get(found, i, &d);
    ids.insert(d->id);
    std::vector<cv::Point2d> q;
    for (int k = 0; k < 4; ++k) q.emplace_back(d->p[k][0], d->p[k][1]);
    EXPECT_NEAR(Side(q) / kPxPerMm, 25.0, 0.1) << "tag " << d->id;
  }
  apriltag_detections_destroy(found);
  apriltag_detector_destroy(detector);
  tag36h11_destroy(family);
  EXPECT_EQ(ids, Ids(t));

  cv::Mat small;  // ours reads views of a few hundred pixels a side: the page at 50 dpi
  cv::resize(grey, small, cv::Size(), 0.25, 0.25, cv::INTER_AREA);
  std::set<int> ours;
  for (const auto& tag : detectors::DetectPlainTagsBlurred(small, 0.5)) ours.insert(tag.tag_id);
  EXPECT_EQ(ours, Ids(t));
}

TEST(PrintedTarget, KalibrGridFoundByArucoAndOursAtEveryId) {
  TargetSpec t;
  t.type = TargetType::kKalibrAprilGrid;
  t.rows = 4;
  t.cols = 5;
  t.tag_size_mm = 25;
  t.spacing = 0.3;
  t.first_id = 0;
  print::TargetPage page;
  const cv::Mat grey = PrintedGrey(t, &page);

  cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  params->markerBorderBits = 2;
  std::vector<std::vector<cv::Point2f>> quads;
  std::vector<int> aruco_ids;
  cv::aruco::detectMarkers(grey, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_APRILTAG_36h11),
                           quads, aruco_ids, params);
  // (aruco's quads of Kalibr tags are pulled in by the corner squares touching them: ids only.)
  EXPECT_EQ(std::set<int>(aruco_ids.begin(), aruco_ids.end()), Ids(t));

  cv::Mat small;  // 50 dpi
  cv::resize(grey, small, cv::Size(), 0.25, 0.25, cv::INTER_AREA);
  std::set<int> ours;
  for (const auto& tag : detectors::DetectKalibrTagsInView(small)) {
    ours.insert(tag.tag_id);
    std::vector<cv::Point2d> q;
    for (const auto& c : tag.corners) q.emplace_back(c.x() + 0.5, c.y() + 0.5);
    EXPECT_NEAR(Side(q) / (kPxPerMm / 4), 25.0, 0.15) << "tag " << tag.tag_id;
  }
  EXPECT_EQ(ours, Ids(t));
}

}  // namespace
}  // namespace omni
