// Dense stereo (stereo/dense_stereo.h) on an image of a known scene: a box room with a
// smooth random texture (box_room.h). The point cloud is compared with the box's true surface
// (an oracle independent of the panoramas, SGBM and the triangulation).
#include "stereo/dense_stereo.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "io/model_file.h"
#include "tests/stereo/box_room.h"

namespace omni::stereo {
namespace {

const std::string kSampleDir = std::string(OMNI_SOURCE_DIR) + "/sample_configs/";

TEST(DenseStereo, PointCloudLiesOnTheTrueBox) {
  const RigModel model(io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml"));
  const Box box;
  const cv::Mat image = RenderBox(model, box);
  PanoramaOptions panorama;
  panorama.width = 1280;
  DepthOptions options;
  options.sigma_px = 1.0;
  const DenseStereo dense(model, panorama, options);
  const DepthFrame frame = dense.Compute(image);
  const int band = (frame.band_row_end - frame.band_row_begin) * frame.disparity.cols;
  ASSERT_GT(band, 0);
  std::vector<double> relative;
  int within_3_sigma = 0;
  double signed_sum = 0;

  for (const DensePoint& p : frame.points) {
    const Eigen::Vector3d point = p.point_in_cam.cast<double>();
    const double error = std::abs(box.DistanceToSurface(point));
    relative.push_back(error / point.head<2>().norm());
    signed_sum += box.DistanceToSurface(point) / point.head<2>().norm();

    within_3_sigma += error <= 3 * p.sigma_mm;
  }
  ASSERT_FALSE(relative.empty());
  const double bias = signed_sum / relative.size();
  std::sort(relative.begin(), relative.end());
  const double fraction = double(frame.points.size()) / band;
  const double median = relative[relative.size() / 2];
  const double p90 = relative[relative.size() * 9 / 10];
  const double in3 = double(within_3_sigma) / frame.points.size();
  std::printf("box room: %zu points (%.0f%% of %d band pixels), |distance to box| / range: "
              "median %.3f%%, 90th pct %.3f%%, mean signed %.3f%% (+: nearer); %.1f%% within 3 sigma (sigma_px 1); remap %.1f ms, "
              "SGBM %.1f ms, triangulation %.1f ms\n",
              frame.points.size(), 100 * fraction, band, 100 * median, 100 * p90, 100 * bias, 100 * in3,
              1e3 * frame.seconds_remap, 1e3 * frame.seconds_sgbm,
              1e3 * frame.seconds_triangulation);
  // With SGBM's own sub-pixel disparity (parabola fit, locks to integers, offsets rounded
  // towards zero) this was median 1.70%, 90th pct 3.07%, mean signed +0.79%; with
  // RefineDisparity (the default) measured 0.37%, 1.22%, +0.12% (the rest: the misaligned rig's
  // panoramas are exact only at the 2 m cylinder, the box walls are at 2.5-3.5 m).
  EXPECT_GT(fraction, 0.8);
  EXPECT_LT(median, 0.006);
  EXPECT_LT(p90, 0.02);
  EXPECT_LT(std::abs(bias), 0.003);
  EXPECT_GT(in3, 0.95);
}

// The disparity against the true one, pixel by pixel, on the ideal (central) rig: the true
// disparity of Xi_1 pixel (u, v) is v minus the Xi_2 row of the box point its ray hits
// (PanoramaGeometry::PanoramaPixel from F2, exact for a central rig). Independent of the
// triangulation: this isolates the matching. SGBM's own sub-pixel values are biased (the cause of
// the dense depth's range bias); RefineDisparity's are not.
struct DisparityErrors {
  double mean = 0, median = 0, p10 = 0, p90 = 0, integer_fraction = 0;
  size_t count = 0;
};

DisparityErrors CompareDisparity(const RigModel& model, const Box& box, const cv::Mat& image,
                                 bool refine) {
  PanoramaOptions panorama;
  panorama.width = 1280;
  DepthOptions options;
  options.refine_subpixel = refine;
  const DenseStereo dense(model, panorama, options);
  const DepthFrame frame = dense.Compute(image);
  const PanoramaLuts& luts = dense.luts();
  std::vector<double> error;
  double sum = 0;
  int integer = 0;
  for (int v = frame.band_row_begin; v < frame.band_row_end; ++v) {
    for (int u = 0; u < frame.disparity.cols; ++u) {
      const float d = frame.disparity.at<float>(v, u);
      if (std::isnan(d)) continue;
      const Eigen::Vector2d m1(luts.map_x[0].at<float>(v, u), luts.map_y[0].at<float>(v, u));
      const auto ray = model.Unproject(m1);
      Eigen::Vector3d p;
      if (!ray || !Hit(box, ray->ray, &p)) continue;
      const double d_true = v - luts.geometry.PanoramaPixel(Mirror::kTwo, p).y();
      error.push_back(d - d_true);
      sum += d - d_true;
      integer += d == std::round(d);
    }
  }
  DisparityErrors e;
  e.count = error.size();
  if (error.empty()) return e;
  std::sort(error.begin(), error.end());
  e.mean = sum / error.size();
  e.median = error[error.size() / 2];
  e.p10 = error[error.size() / 10];
  e.p90 = error[error.size() * 9 / 10];
  e.integer_fraction = double(integer) / error.size();
  std::printf("%s: disparity - true (px) over %zu matches: mean %+.4f, median %+.4f, p10 %+.3f, "
              "p90 %+.3f; %.1f%% integer disparities\n",
              refine ? "refined" : "SGBM", e.count, e.mean, e.median, e.p10, e.p90,
              100 * e.integer_fraction);
  return e;
}

TEST(DenseStereo, RefinedDisparityIsUnbiased) {
  const RigModel model(io::ReadModelFile(kSampleDir + "big_rig_ideal.yaml"));
  const Box box;
  const cv::Mat image = RenderBox(model, box);
  // SGBM's 1/16 px output: measured mean +0.072 px, median +0.089 px, 39% of the disparities
  // integer (pixel locking) and p10..p90 = -0.20..+0.32 px.
  const DisparityErrors sgbm = CompareDisparity(model, box, image, false);
  ASSERT_GT(sgbm.count, 100000u);
  EXPECT_GT(sgbm.mean, 0.04);
  EXPECT_GT(sgbm.integer_fraction, 0.2);
  // Refined: measured mean -0.001 px, median -0.002 px, p10..p90 = -0.08..+0.08 px.
  const DisparityErrors refined = CompareDisparity(model, box, image, true);
  ASSERT_GT(refined.count, 100000u);
  EXPECT_LT(std::abs(refined.mean), 0.01);
  EXPECT_LT(std::abs(refined.median), 0.01);
  EXPECT_LT(refined.p90 - refined.p10, 0.25);
  EXPECT_LT(refined.integer_fraction, 0.05);
}

}  // namespace
}  // namespace omni::stereo
