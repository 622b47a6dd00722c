// The lip detector on POV-Ray renders of the misaligned sample rig (an independent ray tracer)
// against the model's exact images of the lip circles, and the lip-based initial intrinsics.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "detectors/detect_session.h"
#include "detectors/lip_guide.h"
#include "detectors/lips/lip_detector.h"
#include "detectors/lips/lip_intrinsics.h"
#include "io/image_file.h"
#include "io/model_file.h"
#include "synthetic/camera_effects.h"
#include "synthetic/image_effects.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene_file.h"
#include "tests/render_window.h"
#include "tests/temp_dir.h"

namespace omni::detectors {
namespace {

// A grey frame (no lips in it) as the lip guide reads an image.
GuideImage GreyGuideImage() {
  GuideImage image;
  image.image = cv::Mat(960, 1280, CV_16UC1, cv::Scalar(0));
  return image;
}


RigParams ReadSample(const std::string& name) {
  return io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/" + name);
}

// The lip edges DetectLipEdges finds with `prior_name` as its model, against the true rig's exact
// images of their labelled circles; expects every kind of edge the strips show (blue / mirror 1:
// outer edge = outer circle seen directly, inner edge = outer circle via mirror 1; red / mirror 2:
// inner edge = outer circle via mirror 2, its outer edge is the reflex disc's rim), each with at
// least 60 points within mean_px (mean) and p95_px (95th percentile) of the truth.
void ExpectEdgesOnTheTrueCircleImages(const cv::Mat& image, const RigParams& truth_params,
                                      const char* prior_name, double mean_px, double p95_px,
                                      const LipDetectorOptions& options = {}) {
  const RigModel truth(truth_params);
  const RigModel prior(ReadSample(prior_name));
  int found_kinds = 0;
  for (const LipEdgeFit& fit : DetectLipEdges(image, prior, options)) {
    std::vector<double> d;
    for (const Eigen::Vector2d& p : fit.edge.points) {
      d.push_back(DistanceToLipCircleImage(truth, *fit.edge.path, *fit.edge.circle, p));
    }
    ASSERT_FALSE(d.empty());
    std::sort(d.begin(), d.end());
    double mean = 0;
    for (double x : d) mean += x;
    mean /= d.size();
    std::printf("prior %s: lip %d %s edge = %s %s: %zu points (of %d found, %d profiles), "
                "vs truth mean %.3f px, p95 %.3f px, max %.3f px; band %.1f, contrast %.1f, "
                "noise %.2f levels\n", prior_name, MirrorIndex(fit.edge.mirror),
                BandEdgeName(fit.edge.edge), LipCircleName(*fit.edge.circle),
                LipPathName(*fit.edge.path), d.size(), fit.n_found,
                fit.n_profiles, mean, d[d.size() * 95 / 100], d.back(), fit.band, fit.contrast,
                fit.noise);
    EXPECT_LT(mean, mean_px);
    EXPECT_LT(d[d.size() * 95 / 100], p95_px);
    EXPECT_GE(d.size(), 60u);
    EXPECT_EQ(*fit.edge.circle, LipCircle::kOuter);
    found_kinds |= 1 << static_cast<int>(*fit.edge.path);
  }
  EXPECT_EQ(found_kinds, (1 << static_cast<int>(LipPath::kDirect)) |
                             (1 << static_cast<int>(LipPath::kViaMirror1)) |
                             (1 << static_cast<int>(LipPath::kViaMirror2)))
      << "prior " << prior_name;
}

class LipDetectorOnRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new RigParams(ReadSample("big_rig_misaligned.yaml"));
    image_ = new cv::Mat(
        synthetic::ApplyDistortion(testing::RenderLipStrips(*truth_, "misaligned"), *truth_));
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete image_;
  }
  static RigParams* truth_;
  static cv::Mat* image_;
};
RigParams* LipDetectorOnRender::truth_ = nullptr;
cv::Mat* LipDetectorOnRender::image_ = nullptr;

TEST_F(LipDetectorOnRender, EdgePointsLieOnTheTrueCircleImages) {
  ASSERT_FALSE(image_->empty());
  for (const char* prior : {"big_rig_misaligned.yaml", "big_rig_ideal.yaml"}) {
    ExpectEdgesOnTheTrueCircleImages(*image_, *truth_, prior, 0.1, 0.3);
  }
}

TEST_F(LipDetectorOnRender, IntrinsicsFromLips) {
  ASSERT_FALSE(image_->empty());
  const double f_true = 0.5 * (truth_->camera[kFx] + truth_->camera[kFy]);
  // With the rig's true misalignment known, lips give the intrinsics to the detector's accuracy.
  {
    const RigModel prior(*truth_);
    const auto in = InitialIntrinsicsFromLips(DetectLips(*image_, prior), prior);
    ASSERT_TRUE(in);
    std::printf("known misalignment: f %.3f (true mean %.3f) cx %.3f cy %.3f (true %.3f %.3f), "
                "rms %.3f px, %d points, sigma f %.3f cx %.3f cy %.3f\n",
                in->f, f_true, in->cx, in->cy, truth_->camera[kCx], truth_->camera[kCy], in->rms_px,
                in->n_points, in->sigma_f, in->sigma_cx, in->sigma_cy);
    EXPECT_NEAR(in->f / f_true, 1.0, 0.001);
    EXPECT_NEAR(in->cx, truth_->camera[kCx], 0.3);
    EXPECT_NEAR(in->cy, truth_->camera[kCy], 0.3);
  }
  // From the ideal model (as a real camera's initialisation would): f to well under 1%; the
  // principal point absorbs the mirror bodies' tilts (lip_intrinsics.h): f * tilt ~ 7 px here.
  {
    const RigModel prior(ReadSample("big_rig_ideal.yaml"));
    const auto in = InitialIntrinsicsFromLips(DetectLips(*image_, prior), prior);
    ASSERT_TRUE(in);
    std::printf("ideal prior: f %.3f (%.3f%%) cx %+.3f cy %+.3f px off, rms %.3f px, %d points\n",
                in->f, 100 * (in->f / f_true - 1), in->cx - truth_->camera[kCx],
                in->cy - truth_->camera[kCy], in->rms_px, in->n_points);
    EXPECT_NEAR(in->f / f_true, 1.0, 0.007);
    const double tilt_px = f_true * 0.006;  // the sample rig's tilts are <= 0.005 rad
    EXPECT_LT(std::hypot(in->cx - truth_->camera[kCx], in->cy - truth_->camera[kCy]), 1.5 * tilt_px);
  }
}

// Two sessions in one process, each with its own model (two DetectorContexts: tests, Python),
// interleaved image by image: each keeps its own model's prediction (the other's images do not
// replace it), and the edges found with a cache are the edges found without one.
TEST_F(LipDetectorOnRender, EachSessionKeepsItsOwnLipPrediction) {
  ASSERT_FALSE(image_->empty());
  const RigModel truth(*truth_);
  const RigModel prior(ReadSample("big_rig_ideal.yaml"));
  LipPredictionCache truth_session, prior_session;
  const std::vector<LipEdgeObservation> uncached = DetectLips(*image_, truth);
  const std::vector<LipEdgeObservation> first = DetectLips(*image_, truth, {}, &truth_session);
  const auto truth_prediction = truth_session.prediction;
  ASSERT_TRUE(truth_prediction);
  EXPECT_FALSE(prior_session.prediction);
  DetectLips(*image_, prior, {}, &prior_session);
  ASSERT_TRUE(prior_session.prediction);
  EXPECT_NE(prior_session.prediction, truth_prediction);
  const std::vector<LipEdgeObservation> again = DetectLips(*image_, truth, {}, &truth_session);
  EXPECT_EQ(truth_session.prediction, truth_prediction);  // kept, not made again
  ASSERT_EQ(first.size(), uncached.size());
  ASSERT_EQ(again.size(), uncached.size());
  for (size_t k = 0; k < uncached.size(); ++k) {
    EXPECT_EQ(first[k].points, uncached[k].points);
    EXPECT_EQ(again[k].points, uncached[k].points);
  }
  // Other options for the prediction: made again.
  LipDetectorOptions fewer;
  fewer.profiles = 360;
  DetectLips(*image_, truth, fewer, &truth_session);
  EXPECT_NE(truth_session.prediction, truth_prediction);
}

// What a lip-only fit from the ideal model finds instead of the principal point: lips are fixed to
// the mirror bodies, so the fit puts the nominal lip images' centre where the true body puts it
// (LipReferencePointsOf; independent oracle: the true rig's poses, pinhole). Mirror-1 edges
// (direct, via_mirror1) alone land on lip 1's centre image, which is the mirror-1 axis point
// shifted by f * decentre / lip depth (0.3, -0.2 mm at 133 mm: 3.3, -2.2 px here).
TEST_F(LipDetectorOnRender, LipOnlyPrincipalPointIsWhereTheMirrorBodyPutsTheLip) {
  ASSERT_FALSE(image_->empty());
  const RigModel truth(*truth_);
  const RigModel prior(ReadSample("big_rig_ideal.yaml"));
  const std::vector<LipEdgeObservation> edges = DetectLips(*image_, truth);
  const LipReferencePoints ref = LipReferencePointsOf(*truth_);
  const Eigen::Vector2d pp(truth_->camera[kCx], truth_->camera[kCy]);
  const double f_true = 0.5 * (truth_->camera[kFx] + truth_->camera[kFy]);
  std::optional<LipIntrinsics> fits[3];
  for (int mirror = 0; mirror <= 2; ++mirror) {
    std::vector<LipEdgeObservation> used;
    for (const LipEdgeObservation& e : edges) {
      if (mirror == 0 || MirrorIndex(e.mirror) == mirror) used.push_back(e);
    }
    fits[mirror] = InitialIntrinsicsFromLips(used, prior);
    ASSERT_TRUE(fits[mirror]) << "mirror " << mirror;
    const Eigen::Vector2d c(fits[mirror]->cx, fits[mirror]->cy);
    std::printf("edges of mirror %d (0: all): f %+.3f%%, pp - true (%+.3f, %+.3f); distance to "
                "axis1 %.3f, axis2 %.3f, lip1 centre %.3f, lip2 centre in reflex %.3f, axis2 in "
                "reflex %.3f px; rms %.3f px\n", mirror, 100 * (fits[mirror]->f / f_true - 1),
                c.x() - pp.x(), c.y() - pp.y(), (c - ref.axis1).norm(), (c - ref.axis2).norm(),
                (c - ref.lip1_centre).norm(), (c - ref.lip2_centre_in_reflex).norm(),
                (c - ref.axis2_in_reflex).norm(), fits[mirror]->rms_px);
  }
  // Measured: 0.71 px (mirror 1) and 0.81 px (mirror 2); the true principal point is 8.2 and
  // 17.6 px away, mirror 1's axis point 3.5 px (its decentre), so the bar separates them.
  EXPECT_LT((Eigen::Vector2d(fits[1]->cx, fits[1]->cy) - ref.lip1_centre).norm(), 1.0);
  EXPECT_LT((Eigen::Vector2d(fits[2]->cx, fits[2]->cy) - ref.lip2_centre_in_reflex).norm(), 1.0);
  // Both bodies in one fit disagree (rms 1.5 px vs 0.23 / 0.07 px): a sign of misalignment.
  EXPECT_GT(fits[0]->rms_px, 3 * std::max(fits[1]->rms_px, fits[2]->rms_px));
  // f: -0.47% / -0.64% (lens k1 and the bodies' axial offsets: 0.4 mm at 133 mm is 0.3%).
  for (const auto& fit : fits) EXPECT_NEAR(fit->f / f_true, 1.0, 0.008);
}

// The rig as built with its lips painted as a real rig's (big_rig_painted.yaml: dark navy on
// mirror 1, linear <0.02, 0.03, 0.12>; matte red on mirror 2), lit by the room's lamps, through the
// realistic camera (defocus 0.6 / 0.9 px, vignetting, RGGB mosaic + edge-aware demosaic, shot and
// read noise, sRGB, JPEG 92), decoded to linear light as DetectImage does.
class LipDetectorOnPaintedRealisticRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new RigParams(ReadSample("big_rig_painted.yaml"));
    pinhole_ = new cv::Mat(testing::RenderLipStrips(*truth_, "painted", 16));
    jpeg_luma_ = new cv::Mat();
    jpeg_ = new cv::Mat(Camera("realistic", jpeg_luma_));
    sensor_ = new cv::Mat(Camera("{preset: realistic, bayer: none, jpeg_quality: 0}"));
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete pinhole_;
    delete jpeg_;
    delete jpeg_luma_;
    delete sensor_;
  }
  // The camera on the linear render, its file as the camera writes it, decoded to 16-bit linear
  // (and the file's own luma plane, io::ReadStoredLuma, if it has one and `luma` is given).
  static cv::Mat Camera(const std::string& effects_text, cv::Mat* luma = nullptr) {
    if (pinhole_->empty()) return {};
    const synthetic::CameraEffects effects =
        synthetic::ParseCameraEffects(effects_text, "test camera");
    std::vector<uchar> bytes;
    EXPECT_TRUE(synthetic::EncodeCameraImage(
        synthetic::ApplyCamera(*pinhole_, *truth_, effects, 7), effects, &bytes));
    if (luma) *luma = io::ReadStoredLuma(bytes);
    return io::LinearImage(cv::imdecode(bytes, cv::IMREAD_COLOR), io::ToneCurve::kSrgb);
  }
  // The lip detector's options for the JPEG as DetectImage sets them.
  static LipDetectorOptions JpegOptions() {
    LipDetectorOptions options;
    options.chroma_halved = true;
    options.luma = *jpeg_luma_;
    return options;
  }
  static RigParams* truth_;
  static cv::Mat *pinhole_, *jpeg_, *jpeg_luma_, *sensor_;
};
RigParams* LipDetectorOnPaintedRealisticRender::truth_ = nullptr;
cv::Mat* LipDetectorOnPaintedRealisticRender::pinhole_ = nullptr;
cv::Mat* LipDetectorOnPaintedRealisticRender::jpeg_ = nullptr;
cv::Mat* LipDetectorOnPaintedRealisticRender::jpeg_luma_ = nullptr;
cv::Mat* LipDetectorOnPaintedRealisticRender::sensor_ = nullptr;

// The renderer paints each lip with its model colour as a matte surface lit by the room: in the
// linear render the middle of each band is the paint's reflectance times the lamps' and the
// room's light (0.8, pov_scene.cc), channel by channel; self-lit lips were the pure primaries.
TEST_F(LipDetectorOnPaintedRealisticRender, LipsArePaintLitByTheRoom) {
  ASSERT_FALSE(pinhole_->empty());
  RigParams pinhole_rig = *truth_;
  pinhole_rig.distortion = {};  // the render before lens distortion
  const RigModel model(pinhole_rig);
  for (LipPath path : {LipPath::kDirect, LipPath::kViaMirror2}) {
    const Lip& lip = LipOf(pinhole_rig, path);
    const Eigen::Vector3d paint = *LipPaintRgb(lip.color);
    std::vector<double> ratio[3];
    for (int k = 0; k < 3600; ++k) {
      const double phi = 2 * M_PI * k / 3600;
      Eigen::Vector2d inner, outer, mid;
      const auto at = [&](double r, Eigen::Vector2d* px) {
        return ProjectLipPoint(RigBlocksOf(pinhole_rig), model.fixed(), path, r, lip.z, phi, px);
      };
      // The band's middle, at least 1.5 px from both its edges (via mirror 2 the lip is 3.5 px
      // wide; its inner circle, on the mirror's rim, is just out of the mirror's reach).
      if (!at(lip.r_inner + 0.1, &inner) || !at(lip.r_outer, &outer) ||
          !at(0.5 * (lip.r_inner + lip.r_outer), &mid) || (outer - inner).norm() < 3) {
        continue;
      }
      const int u = static_cast<int>(std::lround(mid.x()));
      const int v = static_cast<int>(std::lround(mid.y()));
      if (std::abs(v - pinhole_rig.camera[kCy]) > 55 && std::abs(u - pinhole_rig.camera[kCx]) > 55) {
        continue;  // outside the strips
      }
      const cv::Vec3w bgr = pinhole_->at<cv::Vec3w>(v, u);
      for (int c = 0; c < 3; ++c) ratio[c].push_back(bgr[2 - c] / 65535.0 / paint[c]);
    }
    ASSERT_GE(ratio[0].size(), 40u) << LipPathName(path);
    for (int c = 0; c < 3; ++c) {
      std::nth_element(ratio[c].begin(), ratio[c].begin() + ratio[c].size() / 2, ratio[c].end());
      const double median = ratio[c][ratio[c].size() / 2];
      std::printf("%s (%s) channel %c: render / paint = %.3f (median of %zu)\n",
                  LipPathName(path), lip.color.c_str(), "RGB"[c], median, ratio[c].size());
      EXPECT_NEAR(median, 0.8, 0.04);
    }
  }
}

// Navy is dark (its chroma 0.08 of full scale) and the camera blurs, mosaics, adds noise and
// compresses: the edges are still found on the true circle images. Defocus, vignetting, noise and
// sRGB alone: within 0.1 px. The strips show the bands' four arcs where their edges run along
// the pixel grid, the worst case for the camera's two other effects: the RGGB mosaic samples a
// paint that lives in one channel (navy: blue) every other pixel, so its demosaiced edge moves
// with the edge's phase against the mosaic, and JPEG keeps the chroma at half resolution, so the
// points are placed on the file's own luma as DetectImage does (0.08-0.11 px mean; on the colour
// the navy band read 0.17 px narrower a side, 0.15-0.19 px mean).
TEST_F(LipDetectorOnPaintedRealisticRender, EdgePointsLieOnTheTrueCircleImages) {
  ASSERT_FALSE(sensor_->empty());
  ASSERT_FALSE(jpeg_->empty());
  ASSERT_FALSE(jpeg_luma_->empty());
  for (const char* prior : {"big_rig_misaligned.yaml", "big_rig_ideal.yaml"}) {
    std::printf("defocus, vignetting, noise, sRGB:\n");
    ExpectEdgesOnTheTrueCircleImages(*sensor_, *truth_, prior, 0.1, 0.35);
    std::printf("realistic camera (+ RGGB mosaic, JPEG), placed on the file's luma:\n");
    ExpectEdgesOnTheTrueCircleImages(*jpeg_, *truth_, prior, 0.15, 0.35, JpegOptions());
  }
}

// The mean signed distance of an edge's points to the true image of their circle (+: farther
// from the principal point), per path.
std::map<LipPath, double> SignedOffsets(const cv::Mat& image, const RigParams& truth_params,
                                        const LipDetectorOptions& options) {
  const RigModel truth(truth_params);
  const Eigen::Vector2d pp(truth_params.camera[kCx], truth_params.camera[kCy]);
  std::map<LipPath, double> offsets;
  for (const LipEdgeFit& fit : DetectLipEdges(image, truth, options)) {
    double sum = 0;
    for (const Eigen::Vector2d& p : fit.edge.points) {
      Eigen::Vector2d q;
      const double d = DistanceToLipCircleImage(truth, *fit.edge.path, *fit.edge.circle, p, &q);
      sum += (p - pp).norm() > (q - pp).norm() ? d : -d;
    }
    offsets[*fit.edge.path] = sum / std::max<size_t>(1, fit.edge.points.size());
  }
  return offsets;
}

// JPEG keeps the chroma at half resolution in sRGB: placed on the colour, the dark navy band's
// edges move 0.15-0.2 px (narrower against the strips' black). Placed on the file's own luma Y'
// as DetectImage does (detectors/lips/luma_edge.h: per-pixel band shares, the side colours measured
// where their Y' is, the sensor noise's lift of a dark band's Y' modelled with its variance
// estimated from the image), every edge is within a few hundredths of a pixel on average.
// Without the noise model (variance 0) the navy edges move 0.05-0.1 px (docs/experiments.md).
TEST_F(LipDetectorOnPaintedRealisticRender, JpegEdgesPlacedOnTheLumaMoveLess) {
  ASSERT_FALSE(jpeg_->empty());
  const std::map<LipPath, double> on_colour = SignedOffsets(*jpeg_, *truth_, {});
  const std::map<LipPath, double> on_luma = SignedOffsets(*jpeg_, *truth_, JpegOptions());
  ASSERT_EQ(on_colour.size(), 3u);
  ASSERT_EQ(on_luma.size(), 3u);
  for (const auto& [path, offset] : on_luma) {
    std::printf("%s: mean signed offset on the colour %+.3f px, on the luma %+.3f px\n",
                LipPathName(path), on_colour.at(path), offset);
    EXPECT_LT(std::abs(offset), 0.05) << LipPathName(path);
    EXPECT_LT(std::abs(offset), std::abs(on_colour.at(path))) << LipPathName(path);
  }
}

TEST_F(LipDetectorOnPaintedRealisticRender, IntrinsicsFromLips) {
  ASSERT_FALSE(jpeg_->empty());
  const double f_true = 0.5 * (truth_->camera[kFx] + truth_->camera[kFy]);
  for (const char* prior_name : {"big_rig_painted.yaml", "big_rig_ideal.yaml"}) {
    const RigModel prior(ReadSample(prior_name));
    const auto in = InitialIntrinsicsFromLips(DetectLips(*jpeg_, prior, JpegOptions()), prior);
    ASSERT_TRUE(in) << prior_name;
    std::printf("prior %s: f %+.3f%%, pp - true (%+.3f, %+.3f) px, rms %.3f px, %d points\n",
                prior_name, 100 * (in->f / f_true - 1), in->cx - truth_->camera[kCx],
                in->cy - truth_->camera[kCy], in->rms_px, in->n_points);
    // The ideal prior: lens and the bodies' axial offsets (-0.5%, LipDetectorOnRender).
    const bool ideal = std::string(prior_name) == "big_rig_ideal.yaml";
    EXPECT_NEAR(in->f / f_true, 1.0, ideal ? 0.007 : 0.001);
  }
}

// RMS pixel difference per ring between two models' images of points 1 m from the camera's axis,
// every 10 deg of azimuth and 25 mm of height, where both models see them: where a guide model
// would have the detectors look for a target.
std::array<double, 2> ProjectionDifferenceAt1m(const RigModel& a, const RigModel& b) {
  std::array<double, 2> rms{};
  for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    double sum = 0;
    int n = 0;
    for (int az = 0; az < 360; az += 10) {
      for (double z = -1500; z <= 1500; z += 25) {
        const double t = az * M_PI / 180;
        const Eigen::Vector3d point(1000 * std::cos(t), 1000 * std::sin(t), z);
        const auto pa = a.Project(point, mirror), pb = b.Project(point, mirror);
        if (!pa || !pb) continue;
        sum += (*pa - *pb).squaredNorm();
        ++n;
      }
    }
    EXPECT_GT(n, 100) << "ring " << MirrorIndex(mirror);
    rms[MirrorIndex(mirror) - 1] = std::sqrt(sum / std::max(1, n));
  }
  return rms;
}

// The lip guide (lip_guide.h) on the realistic camera's image: from the design, it moves f and the
// principal point so that the model predicts the rings where the true rig has them (independent
// oracle: the true model's projections); from the true model it changes nothing.
TEST_F(LipDetectorOnPaintedRealisticRender, TheLipGuideCorrectsTheDesignAndLeavesTheTrueModel) {
  ASSERT_FALSE(jpeg_->empty());
  const RigModel truth(*truth_);
  {
    DetectorContext ctx(ReadSample("big_rig_ideal.yaml"), {});
    const std::array<double, 2> before = ProjectionDifferenceAt1m(ctx.model, truth);
    const LipGuide guide = GuideByLips({{*jpeg_, true, *jpeg_luma_}}, &ctx);
    std::printf("%s\n", Describe(guide).c_str());
    ASSERT_TRUE(guide.applied) << guide.why_not;
    const std::array<double, 2> after = ProjectionDifferenceAt1m(ctx.model, truth);
    std::printf("design against the true rig at 1 m: ring 1 %.2f -> %.2f px, ring 2 %.2f -> %.2f "
                "px RMS\n", before[0], after[0], before[1], after[1]);
    EXPECT_LT(after[0], 0.25 * before[0]);
    EXPECT_LT(after[1], 0.1 * before[1]);
    // The layout and the views follow the corrected model.
    EXPECT_EQ(ctx.layout.centre, ComputeRingLayout(ctx.model).centre);
    EXPECT_EQ(cv::norm(ctx.views.front().map_x,
                       MakeRingViews(ctx.model, ctx.view_options).front().map_x, cv::NORM_INF), 0);
  }
  {
    DetectorContext ctx(*truth_, {});
    const LipGuide guide = GuideByLips({{*jpeg_, true, *jpeg_luma_}}, &ctx);
    std::printf("%s\n", Describe(guide).c_str());
    EXPECT_FALSE(guide.applied);
    EXPECT_LT(std::abs(guide.f_after / guide.f_before - 1), 2e-4);
    EXPECT_LT((guide.pp_after - guide.pp_before).norm(), 0.2);
    EXPECT_EQ(ctx.model.params().camera, truth_->camera);
  }
  // A grey image has no lips: the model stays.
  DetectorContext ctx(ReadSample("big_rig_ideal.yaml"), {});
  EXPECT_FALSE(GuideByLips({GreyGuideImage()}, &ctx).applied);
}

// A start whose focal length is 10% off (another camera's f, a wrong design) predicts the lips
// beyond the detector's search: the guide looks for them with f scaled (LipGuideOptions::f_scan)
// and ends where it does from the design (independent oracle: the true model's projections).
TEST_F(LipDetectorOnPaintedRealisticRender, TheLipGuideFindsTheLipsFromAFocalLengthFarOff) {
  ASSERT_FALSE(jpeg_->empty());
  const RigModel truth(*truth_);
  int needed_the_scan = 0;
  for (double scale : {0.90, 1.10}) {
    RigParams start = ReadSample("big_rig_ideal.yaml");
    start.camera[kFx] *= scale;
    start.camera[kFy] *= scale;
    DetectorContext unscanned(start, {});
    LipGuideOptions no_scan;
    no_scan.f_scan.clear();
    const LipGuide without = GuideByLips({{*jpeg_, true, *jpeg_luma_}}, &unscanned, no_scan);
    DetectorContext ctx(start, {});
    const LipGuide guide = GuideByLips({{*jpeg_, true, *jpeg_luma_}}, &ctx);
    std::printf("f x %.2f: without the scan: %s\n  with it: %s\n", scale, Describe(without).c_str(),
                Describe(guide).c_str());
    ASSERT_TRUE(guide.applied) << guide.why_not;
    if (!without.applied) {
      ++needed_the_scan;
      EXPECT_NE(guide.f_scanned, 1.0);
    }
    const std::array<double, 2> after = ProjectionDifferenceAt1m(ctx.model, truth);
    std::printf("against the true rig at 1 m: ring 1 %.2f px, ring 2 %.2f px RMS\n", after[0], after[1]);
    EXPECT_NEAR(guide.f_after / truth_->camera[kFx], 1.0, 0.008);  // as from the design (see above)
    EXPECT_LT(after[0], 2.0);  // 1.43 / 0.78 px from the design (see above)
    EXPECT_LT(after[1], 1.2);
  }
  EXPECT_GE(needed_the_scan, 1);  // else the test does not see the scan
}

TEST_F(LipDetectorOnPaintedRealisticRender, TheLipGuideLeavesGreyImagesAlone) {
  DetectorContext ctx(ReadSample("big_rig_ideal.yaml"), {});
  EXPECT_FALSE(GuideByLips({GreyGuideImage()}, &ctx).applied);
}

TEST(LipDetector, OptionsAreChecked) {
  EXPECT_EQ(LipDetectorOptions().Check(), "");
  LipDetectorOptions options;
  options.min_points = 3;
  EXPECT_EQ(options.Check(), "min_points: expected at least 5 points (an ellipse), got 3");
  const RigModel model(ReadSample("big_rig_ideal.yaml"));
  EXPECT_THROW(DetectLips(cv::Mat(960, 1280, CV_8UC3, cv::Scalar(0)), model, options), std::invalid_argument);
}

TEST(LipDetector, GreyOrWrongSizeImagesGiveNoEdges) {
  const RigModel model(ReadSample("big_rig_ideal.yaml"));
  EXPECT_TRUE(DetectLips(cv::Mat(960, 1280, CV_8UC1, cv::Scalar(0)), model).empty());
  EXPECT_TRUE(DetectLips(cv::Mat(480, 640, CV_8UC3, cv::Scalar(0)), model).empty());
  EXPECT_TRUE(DetectLips(cv::Mat(960, 1280, CV_8UC3, cv::Scalar(0)), model).empty());
  EXPECT_FALSE(InitialIntrinsicsFromLips({}, model));
}

// The guide's line says whether its fit's rms is fine: 0.43-0.45 px where the model fits the
// lips, over 1 px where it does not (the "rms 1.46 px over 6005 edge points").
TEST(LipGuideLine, JudgesTheFitsRms) {
  LipGuide guide;
  guide.applied = true;
  guide.images = 3;
  guide.points = 6005;
  guide.rms_px = 1.46;
  const std::string high = GuideLine(guide);
  EXPECT_NE(high.find("rms 1.46 px over 6005 edge points"), std::string::npos) << high;
  EXPECT_NE(high.find("lip fit rms 1.46 px: high"), std::string::npos) << high;
  EXPECT_NE(high.find("init --posts"), std::string::npos) << high;
  // With the mount in the model its want is not blamed (issue 48).
  guide.mount_in_model = true;
  const std::string mounted = GuideLine(guide);
  EXPECT_NE(mounted.find("lip fit rms 1.46 px: high"), std::string::npos) << mounted;
  EXPECT_EQ(mounted.find("init --posts"), std::string::npos) << mounted;
  EXPECT_NE(mounted.find("its posts are in it"), std::string::npos) << mounted;
  guide.rms_px = 0.45;
  const std::string fine = GuideLine(guide);
  EXPECT_NE(fine.find("lip fit rms 0.45 px: fine"), std::string::npos) << fine;
  // No fit, no judgement.
  LipGuide none;
  none.why_not = "the session does not use the lips (lips: false)";
  EXPECT_EQ(GuideLine(none), Describe(none));
}

}  // namespace
}  // namespace omni::detectors
