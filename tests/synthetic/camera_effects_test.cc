// The synthetic camera (synthetic/camera_effects.h) against independent oracles: the
// Bayer pattern each preset names (a flat colour survives mosaic + demosaic, a wrong channel map
// would swap it), the noise model's variance, sRGB's published values, the vignetting law, and
// which ring each pixel's defocus comes from (RigModel::Unproject's ray trace, not the rim
// ellipse the code fills).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/image_file.h"
#include "io/model_file.h"
#include "model/rig_model.h"
#include "synthetic/camera_effects.h"
#include "synthetic/scene_file.h"

namespace omni::synthetic {
namespace {

RigParams Rig() {
  return io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml");
}

// A rig with no lens distortion, so that ApplyCamera's first step leaves pixels in place.
RigParams RigWithoutLens() {
  RigParams rig = Rig();
  rig.distortion = {0, 0, 0, 0, 0};
  return rig;
}

cv::Mat Flat(const RigParams& rig, cv::Scalar bgr_16bit) {
  return cv::Mat(rig.image_height, rig.image_width, CV_16UC3, bgr_16bit);
}

TEST(CameraEffects, EveryBayerPatternAndDemosaicKeepsAFlatColour) {
  const RigParams rig = RigWithoutLens();
  const cv::Vec3d colour(0.2, 0.5, 0.8);  // B, G, R linear
  for (auto pattern : {io::BayerPattern::kRGGB, io::BayerPattern::kBGGR, io::BayerPattern::kGRBG,
                       io::BayerPattern::kGBRG}) {
    for (auto demosaic : {io::Demosaic::kBilinear, io::Demosaic::kEdgeAware, io::Demosaic::kVng}) {
      SCOPED_TRACE(io::BayerName(pattern) + " " + io::DemosaicName(demosaic));
      CameraEffects e;
      e.bayer = pattern;
      e.demosaic = demosaic;
      const cv::Mat out = ApplyCamera(Flat(rig, cv::Scalar(colour[0] * 65535, colour[1] * 65535,
                                                           colour[2] * 65535)),
                                      rig, e, 1);
      const cv::Vec3b centre = out.at<cv::Vec3b>(rig.image_height / 2, rig.image_width / 2);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(centre[c], colour[c] * 255, 1.0) << "channel " << c;
    }
  }
}

TEST(CameraEffects, RawMosaicSamplesTheNamedChannel) {
  const RigParams rig = RigWithoutLens();
  CameraEffects e;
  e.bayer = io::BayerPattern::kGRBG;
  e.raw_mosaic = true;
  e.bits = 16;
  const cv::Mat out = ApplyCamera(Flat(rig, cv::Scalar(10000, 30000, 50000)), rig, e, 1);
  ASSERT_EQ(out.type(), CV_16U);
  EXPECT_EQ(out.at<uint16_t>(0, 0), 30000);  // G
  EXPECT_EQ(out.at<uint16_t>(0, 1), 50000);  // R
  EXPECT_EQ(out.at<uint16_t>(1, 0), 10000);  // B
  EXPECT_EQ(out.at<uint16_t>(1, 1), 30000);  // G
}

TEST(CameraEffects, SensorNoiseHasTheShotAndReadVariance) {
  const RigParams rig = RigWithoutLens();
  CameraEffects e;
  e.full_well_e = 5000;
  e.read_noise = 2.0;
  e.bits = 16;
  const double x = 0.4;
  const cv::Mat out = ApplyCamera(Flat(rig, cv::Scalar::all(x * 65535)), rig, e, 7);
  cv::Mat f;
  out.convertTo(f, CV_64F, 1.0 / 65535);
  cv::Scalar mean, sd;
  cv::meanStdDev(f.reshape(1), mean, sd);
  const double expected = std::sqrt(x / e.full_well_e + std::pow(e.read_noise / 255, 2));
  EXPECT_NEAR(mean[0], x, 1e-4);
  EXPECT_NEAR(sd[0] / expected, 1.0, 0.01);  // 3.7 M samples: the ratio is known to 0.1%
}

TEST(CameraEffects, SrgbToneCurveAndVignettingFollowTheirLaws) {
  const RigParams rig = RigWithoutLens();
  CameraEffects e;
  e.tone = ToneCurve::kSrgb;
  e.bits = 16;
  const cv::Mat out = ApplyCamera(Flat(rig, cv::Scalar::all(0.5 * 65535)), rig, e, 1);
  // IEC 61966-2-1: linear 0.5 encodes as 0.73536.
  EXPECT_NEAR(out.at<cv::Vec3w>(100, 100)[1] / 65535.0, 0.73536, 2e-5);

  CameraEffects v;
  v.vignetting = 0.3;
  v.bits = 16;
  const cv::Mat vig = ApplyCamera(Flat(rig, cv::Scalar::all(0.8 * 65535)), rig, v, 1);
  const int cx = static_cast<int>(std::round(rig.camera[kCx])), cy = static_cast<int>(std::round(rig.camera[kCy]));
  EXPECT_NEAR(vig.at<cv::Vec3w>(cy, cx)[0] / 65535.0, 0.8, 1e-3);
  // The corner farthest from the principal point (642.3, 476.8) is the bottom left.
  EXPECT_NEAR(vig.at<cv::Vec3w>(rig.image_height - 1, 0)[0] / 65535.0, 0.8 * 0.7, 1e-4);
}

// The inner-ring weight is 1 exactly where the ray trace says mirror 2 (the inner ring) and 0
// where it says mirror 1, away from the reflex disc's rim.
TEST(CameraEffects, DefocusRingsAreTheRingsTheModelSees) {
  const RigParams rig = Rig();
  const RigModel model(rig);
  const cv::Mat w = InnerRingWeight(rig, 1.5);
  int checked[2] = {0, 0}, wrong = 0;
  for (int v = 2; v < rig.image_height; v += 7) {
    for (int u = 3; u < rig.image_width; u += 7) {
      const auto ray = model.Unproject(Eigen::Vector2d(u, v));
      if (!ray) continue;
      const bool inner = ray->mirror == Mirror::kTwo;
      // Away from the rim: the weight's neighbourhood has settled.
      const float wv = w.at<float>(v, u);
      if (wv > 0.01f && wv < 0.99f) continue;
      ++checked[inner];
      if ((wv > 0.5f) != inner) ++wrong;
    }
  }
  EXPECT_GT(checked[0], 1000);
  EXPECT_GT(checked[1], 1000);
  EXPECT_EQ(wrong, 0);
}

TEST(CameraEffects, PresetsAndTheirYamlOverrides) {
  for (const std::string& name : CameraPresetNames()) {
    const auto e = CameraPreset(name);
    ASSERT_TRUE(e.has_value()) << name;
    EXPECT_EQ(e->Check(), "") << name;
    EXPECT_EQ(e->IsClean(), name == "clean") << name;
  }
  const CameraEffects e = ParseCameraEffects("{preset: realistic, defocus_sigma_px: [0.2, 0.4], jpeg_quality: 0}", "test");
  EXPECT_EQ(e.defocus_sigma_px[0], 0.2);
  EXPECT_EQ(e.defocus_sigma_px[1], 0.4);
  EXPECT_EQ(e.jpeg_quality, 0);
  EXPECT_EQ(e.bayer, io::BayerPattern::kRGGB);
  EXPECT_THROW(ParseCameraEffects("grainy", "t"), io::InputError);
  EXPECT_THROW(ParseCameraEffects("{bits: 16, jpeg_quality: 90}", "t"), io::InputError);
  EXPECT_THROW(ParseCameraEffects("{bayer: RGBG}", "t"), io::InputError);
  EXPECT_THROW(ParseCameraEffects("{defocus: 1}", "t"), io::InputError);
}

// The chroma resolution of a JPEG is read from its frame header (io::HasHalvedChroma): the
// camera's JPEG (libjpeg's default 4:2:0) says halved, the same file with its luma sampling
// factors rewritten to 1x1 (4:4:4) says not, and so do a grey JPEG, a PNG, and cut or foreign
// bytes (no crash).
TEST(CameraEffects, JpegChromaResolutionIsReadFromTheFrameHeader) {
  const RigParams rig = RigWithoutLens();
  const CameraEffects realistic = ParseCameraEffects("realistic", "test camera");
  std::vector<uchar> jpeg;
  ASSERT_TRUE(EncodeCameraImage(ApplyCamera(Flat(rig, {9000, 20000, 30000}), rig, realistic, 1),
                                realistic, &jpeg));
  EXPECT_TRUE(io::HasHalvedChroma(jpeg));
  // The luma's sampling factors: the first component of the first frame header (FF C0).
  size_t sof = 0;
  for (size_t i = 2; i + 1 < jpeg.size(); ++i) {
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xC0) {
      sof = i;
      break;
    }
  }
  ASSERT_GT(sof, 0u);
  ASSERT_EQ(jpeg[sof + 9], 3);       // components
  EXPECT_EQ(jpeg[sof + 11], 0x22);   // luma 2x2: chroma (1x1) at half resolution both ways
  std::vector<uchar> full = jpeg;
  full[sof + 11] = 0x11;
  EXPECT_FALSE(io::HasHalvedChroma(full));
  std::vector<uchar> grey, png;
  ASSERT_TRUE(cv::imencode(".jpg", cv::Mat(64, 64, CV_8UC1, cv::Scalar(90)), grey));
  EXPECT_FALSE(io::HasHalvedChroma(grey));
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(64, 64, CV_8UC3, cv::Scalar(1, 2, 3)), png));
  EXPECT_FALSE(io::HasHalvedChroma(png));
  for (size_t cut : {size_t{0}, size_t{3}, sof, sof + 10}) {
    EXPECT_FALSE(io::HasHalvedChroma(std::vector<uchar>(jpeg.begin(), jpeg.begin() + cut))) << cut;
  }
  EXPECT_FALSE(io::HasHalvedChroma(std::vector<uchar>(300, 0xFF)));
  // From a file: the same answer; a missing file is not halved.
  const std::string path = ::testing::TempDir() + "/omni_chroma_test.jpg";
  cv::imwrite(path, cv::Mat(64, 64, CV_8UC3, cv::Scalar(10, 200, 30)));
  EXPECT_TRUE(io::HasHalvedChroma(path));
  std::remove(path.c_str());
  EXPECT_FALSE(io::HasHalvedChroma(path));
}

}  // namespace
}  // namespace omni::synthetic
