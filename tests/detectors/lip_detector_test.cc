// The lip detector on POV-Ray renders of the misaligned sample rig (an independent ray tracer)
// against the model's exact images of the lip circles, and the lip-based initial intrinsics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/synthetic/image_effects.h"
#include "calib/synthetic/pov_scene.h"
#include "detectors/lip_detector.h"
#include "detectors/lip_intrinsics.h"
#include "model/io/model_file.h"
#include "tests/temp_dir.h"

namespace omni::detectors {
namespace {

RigParams ReadSample(const std::string& name) {
  return io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/" + name);
}

// The rig with nothing in front of it, rendered in a horizontal and a vertical strip through the
// principal point (4 arcs of every band; full frames are slow), lens distortion applied.
cv::Mat RenderLipStrips(const RigParams& rig, const std::string& tag) {
  const std::string dir = omni::testing::UniqueTempDir("omni_lips_" + tag);
  std::filesystem::create_directories(dir);
  const int cx = static_cast<int>(rig.camera[2]), cy = static_cast<int>(rig.camera[3]);
  cv::Mat combined;
  for (int strip = 0; strip < 2; ++strip) {
    synthetic::RenderOptions opt;
    opt.width = rig.image_width;
    opt.height = rig.image_height;
    if (strip == 0) {
      opt.col0 = 0, opt.col1 = rig.image_width, opt.row0 = cy - 60, opt.row1 = cy + 60;
    } else {
      opt.col0 = cx - 60, opt.col1 = cx + 60, opt.row0 = 0, opt.row1 = rig.image_height;
    }
    const std::string png = dir + "/strip" + std::to_string(strip) + ".png";
    std::string error;
    EXPECT_TRUE(synthetic::RenderScene(synthetic::PovSceneText(rig, {}), png, opt, &error)) << error;
    const cv::Mat img = cv::imread(png, cv::IMREAD_COLOR);
    if (img.empty()) return {};
    combined = combined.empty() ? img : cv::max(combined, img);
  }
  return synthetic::ApplyDistortion(combined, rig);
}

// Distance of a pixel to the model's image of a lip circle along a path (nearest azimuth by a
// coarse-to-fine scan).
double DistanceToCircleImage(const RigModel& model, LipPath path, LipCircle circle,
                             const Eigen::Vector2d& p) {
  double phi = std::atan2(p.y() - model.params().camera[3], p.x() - model.params().camera[2]);
  double best = 1e9;
  for (double step : {1e-2, 5e-4, 2e-5, 1e-6}) {
    double best_phi = phi;
    for (int k = -40; k <= 40; ++k) {
      const auto q = ProjectLipPoint(model, path, circle, phi + k * step);
      if (q && (*q - p).norm() < best) {
        best = (*q - p).norm();
        best_phi = phi + k * step;
      }
    }
    phi = best_phi;
  }
  return best;
}

class LipDetectorOnRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new RigParams(ReadSample("big_rig_misaligned.yaml"));
    image_ = new cv::Mat(RenderLipStrips(*truth_, "misaligned"));
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
  const RigModel truth(*truth_);
  for (const char* prior_name : {"big_rig_misaligned.yaml", "big_rig_ideal.yaml"}) {
    const RigModel prior(ReadSample(prior_name));
    const std::vector<LipEdgeFit> fits = DetectLipEdges(*image_, prior);
    // Blue: outer edge = outer circle seen directly, inner edge = outer circle via mirror 1;
    // red: inner edge = outer circle via mirror 2 (the outer edge is the reflex disc's rim).
    int found_kinds = 0;
    for (const LipEdgeFit& fit : fits) {
      std::vector<double> d;
      for (const Eigen::Vector2d& p : fit.edge.points) {
        d.push_back(DistanceToCircleImage(truth, fit.path, fit.circle, p));
      }
      ASSERT_FALSE(d.empty());
      std::sort(d.begin(), d.end());
      double mean = 0;
      for (double x : d) mean += x;
      mean /= d.size();
      std::printf("prior %s: lip %d %s edge = %s %s: %zu points (of %d found, %d profiles), "
                  "vs truth mean %.3f px, p95 %.3f px, max %.3f px\n",
                  prior_name, fit.edge.mirror, fit.edge.edge.c_str(), fit.edge.circle.c_str(),
                  fit.edge.path.c_str(), d.size(), fit.n_found, fit.n_profiles, mean,
                  d[d.size() * 95 / 100], d.back());
      EXPECT_LT(mean, 0.1);
      EXPECT_LT(d[d.size() * 95 / 100], 0.3);
      EXPECT_GE(d.size(), 60u);
      EXPECT_EQ(fit.circle, LipCircle::kOuter);
      found_kinds |= 1 << static_cast<int>(fit.path);
    }
    EXPECT_EQ(found_kinds, (1 << static_cast<int>(LipPath::kDirect)) |
                               (1 << static_cast<int>(LipPath::kViaMirror1)) |
                               (1 << static_cast<int>(LipPath::kViaMirror2)));
  }
}

TEST_F(LipDetectorOnRender, IntrinsicsFromLips) {
  ASSERT_FALSE(image_->empty());
  const double f_true = 0.5 * (truth_->camera[0] + truth_->camera[1]);
  // With the rig's true misalignment known, lips give the intrinsics to the detector's accuracy.
  {
    const RigModel prior(*truth_);
    const auto in = InitialIntrinsicsFromLips(DetectLips(*image_, prior), prior);
    ASSERT_TRUE(in);
    std::printf("known misalignment: f %.3f (true mean %.3f) cx %.3f cy %.3f (true %.3f %.3f), "
                "rms %.3f px, %d points, sigma f %.3f cx %.3f cy %.3f\n",
                in->f, f_true, in->cx, in->cy, truth_->camera[2], truth_->camera[3], in->rms_px,
                in->n_points, in->sigma_f, in->sigma_cx, in->sigma_cy);
    EXPECT_NEAR(in->f / f_true, 1.0, 0.001);
    EXPECT_NEAR(in->cx, truth_->camera[2], 0.3);
    EXPECT_NEAR(in->cy, truth_->camera[3], 0.3);
  }
  // From the ideal model (as a real camera's initialisation would): f to well under 1%; the
  // principal point absorbs the mirror bodies' tilts (lip_intrinsics.h): f * tilt ~ 7 px here.
  {
    const RigModel prior(ReadSample("big_rig_ideal.yaml"));
    const auto in = InitialIntrinsicsFromLips(DetectLips(*image_, prior), prior);
    ASSERT_TRUE(in);
    std::printf("ideal prior: f %.3f (%.3f%%) cx %+.3f cy %+.3f px off, rms %.3f px, %d points\n",
                in->f, 100 * (in->f / f_true - 1), in->cx - truth_->camera[2],
                in->cy - truth_->camera[3], in->rms_px, in->n_points);
    EXPECT_NEAR(in->f / f_true, 1.0, 0.007);
    const double tilt_px = f_true * 0.006;  // the sample rig's tilts are <= 0.005 rad
    EXPECT_LT(std::hypot(in->cx - truth_->camera[2], in->cy - truth_->camera[3]), 1.5 * tilt_px);
  }
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
  const std::vector<io::LipEdge> edges = DetectLips(*image_, truth);
  const LipReferencePoints ref = LipReferencePointsOf(*truth_);
  const Eigen::Vector2d pp(truth_->camera[2], truth_->camera[3]);
  const double f_true = 0.5 * (truth_->camera[0] + truth_->camera[1]);
  std::optional<LipIntrinsics> fits[3];
  for (int mirror = 0; mirror <= 2; ++mirror) {
    std::vector<io::LipEdge> used;
    for (const io::LipEdge& e : edges) {
      if (mirror == 0 || e.mirror == mirror) used.push_back(e);
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

TEST(LipDetector, GreyOrWrongSizeImagesGiveNoEdges) {
  const RigModel model(ReadSample("big_rig_ideal.yaml"));
  EXPECT_TRUE(DetectLips(cv::Mat(960, 1280, CV_8UC1, cv::Scalar(0)), model).empty());
  EXPECT_TRUE(DetectLips(cv::Mat(480, 640, CV_8UC3, cv::Scalar(0)), model).empty());
  EXPECT_TRUE(DetectLips(cv::Mat(960, 1280, CV_8UC3, cv::Scalar(0)), model).empty());
  EXPECT_FALSE(InitialIntrinsicsFromLips({}, model));
}

}  // namespace
}  // namespace omni::detectors
