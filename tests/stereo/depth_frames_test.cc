// stereo/depth_frames.h's images and figures of a frame, and triangulation_inputs.h's measured
// corner noise, on hand-made frames and models.
#include "stereo/depth_frames.h"

#include <cmath>

#include <gtest/gtest.h>

#include "stereo/triangulation_inputs.h"

namespace omni::stereo {
namespace {

DepthFrame FrameOf(std::initializer_list<float> disparities, std::initializer_list<float> sigmas) {
  DepthFrame frame;
  frame.disparity = cv::Mat(1, static_cast<int>(disparities.size()), CV_32FC1);
  int u = 0;
  for (float d : disparities) frame.disparity.at<float>(0, u++) = d;
  for (float s : sigmas) {
    DensePoint p;
    p.sigma_mm = s;
    frame.points.push_back(p);
  }
  return frame;
}

TEST(DepthFrames, DisparityImagesWithNoMatchAtZero) {
  const DepthFrame frame = FrameOf({2.5f, NAN, 32.0f, 64.0f}, {});
  const cv::Mat d16 = Disparity16(frame);
  ASSERT_EQ(d16.type(), CV_16UC1);
  EXPECT_EQ(d16.at<uint16_t>(0, 0), 40);  // 16 x 2.5
  EXPECT_EQ(d16.at<uint16_t>(0, 1), 0);
  EXPECT_EQ(d16.at<uint16_t>(0, 2), 512);
  const cv::Mat view = DisparityView(frame, 64);
  ASSERT_EQ(view.type(), CV_8UC1);
  EXPECT_EQ(view.at<uint8_t>(0, 1), 0);
  EXPECT_EQ(view.at<uint8_t>(0, 2), 128);  // 32 * 255 / 64 = 127.5, rounded
  EXPECT_EQ(view.at<uint8_t>(0, 3), 255);
}

TEST(DepthFrames, MedianSigma) {
  EXPECT_EQ(MedianSigma(FrameOf({}, {})), 0);
  EXPECT_FLOAT_EQ(MedianSigma(FrameOf({}, {5, 1, 3})), 3);
  EXPECT_FLOAT_EQ(MedianSigma(FrameOf({}, {4, 1, 3, 2})), 3);  // the upper of the middle two
}

TEST(TriangulationInputs, MeasuredCornerNoiseIsTheResidualRmsOverSqrt2) {
  RigParams rig;
  double s1 = -1, s2 = -1;
  EXPECT_FALSE(MeasuredCornerNoise(rig, &s1, &s2));  // not calibrated
  rig.calibration.emplace();
  rig.calibration->per_mirror_rms_px = {0.2, 0};
  EXPECT_FALSE(MeasuredCornerNoise(rig, &s1, &s2));  // one ring without
  EXPECT_EQ(s1, -1);
  rig.calibration->per_mirror_rms_px = {0.2, 0.4};
  ASSERT_TRUE(MeasuredCornerNoise(rig, &s1, &s2));
  EXPECT_DOUBLE_EQ(s1, 0.2 / std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(s2, 0.4 / std::sqrt(2.0));
}

}  // namespace
}  // namespace omni::stereo
