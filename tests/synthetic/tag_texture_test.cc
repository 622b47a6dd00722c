// The tag-grid textures against detectors that know nothing of our code: libapriltag finds every
// tag of the plain grid, OpenCV's aruco (DICT_APRILTAG_36h11, 2 border bits) every tag of the
// Kalibr grid, with the right ids, and each detected corner k maps back to model/target.h's
// CornerInTarget(4 * id + k).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "model/target.h"
#include "synthetic/tag_texture.h"

namespace omni {
namespace {

// A detected corner at texture pixel (u, v) (OpenCV convention: pixel centres at integers) in the
// target frame: column 0 starts at the sheet's x0, texel edges lie at half-integers.
Eigen::Vector2d TextureToTarget(const TargetSpec& spec, const synthetic::TagTexture& t,
                                double u, double v) {
  const Eigen::Vector4d sheet = SheetBounds(spec);
  return Eigen::Vector2d(sheet[0] + (u + 0.5) * t.mm_per_pixel,
                         sheet[1] + (v + 0.5) * t.mm_per_pixel);
}

struct CornerErrors {
  int tags = 0;
  double max_mm = 0, mean_mm = 0;
  int n = 0;
  void Add(double e) {
    max_mm = std::max(max_mm, e);
    mean_mm += e;
    ++n;
  }
};

TargetSpec Grid(TargetType type, int rows, int cols, double tag_size, double spacing, int first_id) {
  TargetSpec spec;
  spec.type = type;
  spec.rows = rows;
  spec.cols = cols;
  spec.tag_size_mm = tag_size;
  spec.spacing = spacing;
  spec.first_id = first_id;
  return spec;
}

TEST(TagTexture, PixelsPerBitPutEveryEdgeOnATexelBoundary) {
  // 0.3 * 8 bits = 2.4 bits: 5 pixels per bit make the gap 12 pixels.
  EXPECT_EQ(synthetic::TexturePixelsPerBit(Grid(TargetType::kAprilTagGrid, 2, 2, 30, 0.3, 0)), 5);
  EXPECT_EQ(synthetic::TexturePixelsPerBit(Grid(TargetType::kKalibrAprilGrid, 2, 2, 30, 0.3, 0)), 4);
  EXPECT_EQ(synthetic::TexturePixelsPerBit(Grid(TargetType::kKalibrAprilGrid, 2, 2, 30, 0.25, 0)), 4);
  std::string error;
  EXPECT_FALSE(synthetic::CheckTagGrid(Grid(TargetType::kAprilTagGrid, 2, 2, 30, 0.1, 0), &error));
  EXPECT_FALSE(synthetic::CheckTagGrid(Grid(TargetType::kAprilTagGrid, 20, 30, 30, 0.3, 0), &error));
  EXPECT_NE(error.find("first_id"), std::string::npos) << error;
  EXPECT_FALSE(synthetic::CheckTagGrid(Grid(TargetType::kKalibrAprilGrid, 2, 2, 30, 0.123456, 0), &error));
  const TargetSpec spec = Grid(TargetType::kKalibrAprilGrid, 3, 4, 30, 0.3, 0);
  const auto t = synthetic::MakeTagTexture(spec);
  const Eigen::Vector4d sheet = SheetBounds(spec);
  EXPECT_NEAR(t.image.cols * t.mm_per_pixel, sheet[2] - sheet[0], 1e-9);
  EXPECT_NEAR(t.image.rows * t.mm_per_pixel, sheet[3] - sheet[1], 1e-9);
}

TEST(TagTexture, PlainGridTagsAreLibapriltagsOwnImages) {
  // Independent of our bit layout: each tag's texels equal apriltag_to_image's picture.
  const TargetSpec spec = Grid(TargetType::kAprilTagGrid, 2, 3, 30, 0.3, 40);
  const auto t = synthetic::MakeTagTexture(spec, 1);  // 1 texel per bit where possible
  apriltag_family_t* family = tag36h11_create();
  const int n = t.pixels_per_bit;
  for (int id = spec.first_id; id < spec.first_id + spec.rows * spec.cols; ++id) {
    int row = 0, col = 0;
    ASSERT_TRUE(TagCell(spec, id, &row, &col));
    image_u8_t* lib = apriltag_to_image(family, id);  // black square at 1..8 of 10
    const Eigen::Vector3d top_left = CornerInTarget(spec, 4 * id + 3);
    const Eigen::Vector4d sheet = SheetBounds(spec);
    const int u0 = static_cast<int>(std::lround((top_left.x() - sheet[0]) / t.mm_per_pixel));
    const int v0 = static_cast<int>(std::lround((top_left.y() - sheet[1]) / t.mm_per_pixel));
    int mismatches = 0;
    for (int y = 0; y < lib->height; ++y) {
      for (int x = 0; x < lib->width; ++x) {
        const int u = u0 + (x - 1) * n + n / 2, v = v0 + (y - 1) * n + n / 2;
        mismatches += (t.image.at<uint8_t>(v, u) > 127) != (lib->buf[y * lib->stride + x] > 127);
      }
    }
    EXPECT_EQ(mismatches, 0) << "tag " << id;
    std::free(lib->buf);  // image_u8_destroy is not exported by Debian's libapriltag
    std::free(lib);
  }
  tag36h11_destroy(family);
}

TEST(TagTexture, LibapriltagDetectsEveryPlainGridTagAtItsCorners) {
  const TargetSpec spec = Grid(TargetType::kAprilTagGrid, 3, 4, 30, 0.3, 7);
  const auto t = synthetic::MakeTagTexture(spec);
  cv::Mat image = t.image.clone();
  image_u8_t im{image.cols, image.rows, static_cast<int32_t>(image.step), image.data};
  apriltag_family_t* family = tag36h11_create();
  apriltag_detector_t* detector = apriltag_detector_create();
  apriltag_detector_add_family(detector, family);
  detector->quad_decimate = 1.0;
  detector->nthreads = 1;
  zarray_t* detections = apriltag_detector_detect(detector, &im);
  std::map<int, int> found;
  CornerErrors err;
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det;
    zarray_get(detections, i, &det);
    ++found[det->id];
    ASSERT_TRUE(HasCorner(spec, 4 * det->id)) << "unexpected id " << det->id;
    EXPECT_EQ(det->hamming, 0);
    for (int k = 0; k < 4; ++k) {
      // libapriltag's p[] wrap the tag counter-clockwise from its bottom-left, as our k, but its
      // pixel coordinates put pixel centres at +0.5 (corner of pixel (0,0) at the origin).
      const Eigen::Vector2d at = TextureToTarget(spec, t, det->p[k][0] - 0.5, det->p[k][1] - 0.5);
      const Eigen::Vector3d truth = CornerInTarget(spec, 4 * det->id + k);
      err.Add((at - truth.head<2>()).norm());
    }
  }
  apriltag_detections_destroy(detections);
  apriltag_detector_destroy(detector);
  tag36h11_destroy(family);
  err.mean_mm /= std::max(1, err.n);
  std::printf("apriltag_grid %dx%d: %zu/%d tags found, %d px/bit (%.3f mm/px), corner error mean "
              "%.4f px, max %.4f px\n", spec.rows, spec.cols, found.size(), spec.rows * spec.cols,
              t.pixels_per_bit, t.mm_per_pixel, err.mean_mm / t.mm_per_pixel,
              err.max_mm / t.mm_per_pixel);
  EXPECT_EQ(found.size(), static_cast<size_t>(spec.rows * spec.cols));
  for (const auto& [id, count] : found) EXPECT_EQ(count, 1) << "tag " << id;
  // Corners to a quarter texel (a texel is 1/5 of a tag bit). libapriltag's corners sit a constant
  // ~0.125 px up and left of the texel edges (its edge refinement), the same for every corner.
  EXPECT_LT(err.max_mm, 0.25 * t.mm_per_pixel);
}

TEST(TagTexture, ArucoDetectsEveryKalibrGridTagAtItsCorners) {
  const TargetSpec spec = Grid(TargetType::kKalibrAprilGrid, 3, 4, 30, 0.3, 3);
  const auto t = synthetic::MakeTagTexture(spec);
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(cv::aruco::DICT_APRILTAG_36h11);
  const cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  params->markerBorderBits = 2;
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(t.image, dictionary, corners, ids, params);
  std::map<int, int> found;
  CornerErrors err;
  for (size_t i = 0; i < ids.size(); ++i) {
    ++found[ids[i]];
    ASSERT_TRUE(HasCorner(spec, 4 * ids[i])) << "unexpected id " << ids[i];
    for (int k = 0; k < 4; ++k) {
      // aruco's corners run clockwise from its marker's top-left, but its DICT_APRILTAG_36h11
      // patterns are libapriltag's turned by 180 degrees: its corners 0..3 are our k = 1, 0, 3, 2.
      const cv::Point2f p = corners[i][k ^ 1];
      const Eigen::Vector2d at = TextureToTarget(spec, t, p.x, p.y);
      err.Add((at - CornerInTarget(spec, 4 * ids[i] + k).head<2>()).norm());
    }
  }
  err.mean_mm /= std::max(1, err.n);
  std::printf("kalibr_aprilgrid %dx%d: %zu/%d tags found, %d px/bit (%.3f mm/px), corner error "
              "mean %.4f px, max %.4f px\n", spec.rows, spec.cols, found.size(),
              spec.rows * spec.cols, t.pixels_per_bit, t.mm_per_pixel,
              err.mean_mm / t.mm_per_pixel, err.max_mm / t.mm_per_pixel);
  EXPECT_EQ(found.size(), static_cast<size_t>(spec.rows * spec.cols));
  for (const auto& [id, count] : found) EXPECT_EQ(count, 1) << "tag " << id;
  EXPECT_LT(err.max_mm, 0.25 * t.mm_per_pixel);
}

}  // namespace
}  // namespace omni
