// A single-mirror camera's non-central part (mirror1_pose) from a few photos of one board in one
// sector at one range, as the public paracatadioptric sets are taken (Mei's: 10 photos, a 6x8
// board 0.28-0.38 m away in one quarter of the view): the calibration keeps it only where the
// photos decide it (calib/central_decision.h). Real Ceres solves on exact synthetic corners plus
// known pixel noise. Against the truth: the calibration is not refused, the held-out photos are
// predicted within 3% of the true model's RMS, and the offset reported for the non-central fit
// is honest (the truth within 3 sigma of it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "calib/calibrate.h"
#include "calib/single_mirror_summary.h"
#include "model/central_mirror.h"
#include "model/model_derived.h"
#include "synthetic/scene.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

// `images` photos of one 6x8 board of 42 mm squares facing the axis, each its centre at a
// range of 280..380 mm from the mirror's near focus, at azimuths az0..az0+90 deg and elevations
// -35..-5 deg (a pseudo-random walk from `seed`).
testing::SyntheticSession OneSectorSession(const RigParams& truth, int images, unsigned seed) {
  testing::SyntheticSession s;
  const RigModel model(truth);
  const TargetSpec board = testing::Chessboard(6, 8, 42.0);
  s.scene.targets = {board};
  s.targets = {board};
  const Eigen::Vector3d focus = ComputeModelDerived(truth).focus1_in_cam;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < images; ++i) {
    const double az = (20 + 90 * u(rng)) * M_PI / 180, el = (-35 + 30 * u(rng)) * M_PI / 180;
    const double range = 280 + 100 * u(rng);
    const Eigen::Vector3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                              std::sin(el));
    synthetic::SceneImage image;
    image.name = "photo" + std::to_string(i);
    image.placements.push_back(synthetic::PlaceFacingAxis(board, 0, focus + range * dir));
    s.scene.images.push_back(image);
    s.truth.push_back(synthetic::ComputeTruth(model, s.scene, image));
  }
  return s;
}

struct Scored {
  CalibrationResult result;
  double held_out_rms = 0, true_held_out_rms = 0;
};

Scored CalibrateAndScore(const RigParams& truth, const RigParams& start, const std::string& noncentral,
                      unsigned seed, bool size_prior = false) {
  const auto session = OneSectorSession(truth, 7, seed);
  const Observations detections = testing::NoisyDetections(session, 0.25, seed + 100);
  CalibrationOptions options;
  options.estimate = {"camera", "distortion", "mirror1_shape", "mirror1_pose"};
  options.profile = "off";
  options.use_lips = false;
  options.noncentral = noncentral;
  // The mirror's size as measured (R within 0.01 mm): from corners alone a perspective camera
  // cannot tell a mirror twice the size twice as far. Without it R is held (the start's).
  if (size_prior) options.priors = {{"mirror1_shape", ShapePrior{0.01, 0}}};
  options.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  Scored run;
  run.result = Calibrate(start, session.targets, detections, options);
  std::fprintf(stderr, "%s", ResultTable(run.result, &truth).c_str());
  std::fprintf(stderr, "%s", SingleMirrorText(SummariseSingleMirror(run.result)).c_str());
  const auto held_out = OneSectorSession(truth, 4, seed + 1);
  const Observations held = testing::NoisyDetections(held_out, 0.25, seed + 200);
  CalibrationOptions score;
  score.estimate = {};
  score.use_lips = false;
  run.true_held_out_rms = Calibrate(truth, held_out.targets, held, score).residuals.rms_px;
  run.held_out_rms =
      Calibrate(run.result.estimate.rig, held_out.targets, held, score).residuals.rms_px;
  std::fprintf(stderr, "noncentral: %s, held-out rms %.4f px (truth %.4f px)\n",
               noncentral.c_str(), run.held_out_rms, run.true_held_out_rms);
  return run;
}

RigParams PerspectiveTruth() {
  CentralMirror central{Conic<double>{20.0, -2.2}, LensKind::kPerspective, 800, 0};
  RigParams truth = MakeSingleRig(central.mirror, central.lens, central.CameraBelowVertexMm(), 30,
                                  5, Pinhole<double>{800, 800, 640, 480, 0}, 1280, 960);
  truth.kind = ModelKind::kNoncentral;
  truth.mirror1_pose = {0.003, -0.002, 0.3, -0.2, 0.5};
  truth.distortion = {-0.04, 0.006, 0, 0, 0};
  return truth;
}

RigParams StartOf(const RigParams& truth, double k, std::array<double, 5> camera) {
  RigParams start = truth;
  start.kind = ModelKind::kIdeal;
  start.mirror1_shape[kShapeK] = k;
  start.mirror1_pose = {0, 0, 0, 0, 0};
  start.distortion = {0, 0, 0, 0, 0};
  start.camera = camera;
  return start;
}

// Mei's kind of camera: a paraboloid (R 30 mm, rim 30 mm) behind a telecentric lens of 10 px
// per mm, its axis 0.1 deg off the lens's.
RigParams TelecentricTruth() {
  RigParams truth = MakeSingleRig(Conic<double>{30.0, -1.0}, LensKind::kTelecentric, 60, 30, 4.5,
                                  Pinhole<double>{10.0, 10.0, 640, 512, 0}, 1280, 1024);
  truth.kind = ModelKind::kNoncentral;
  truth.mirror1_pose = {0.0015, -0.001, 0, 0, 0};
  return truth;
}

// The same camera declared with a perspective lens (bench/single_mirror_session.py's start): a
// hyperboloid K -2 whose rim lies in its near focus's plane, the camera at its far focus, the
// focal length putting the rim at its radius in the image (300 px).
RigParams PerspectiveStartOf(const RigParams& truth) {
  const double r_rim = 30, e = std::sqrt(2.0), k = -2;
  double lo = 1e-3, hi = 100 * r_rim, r = 0;
  for (int i = 0; i < 200; ++i) {
    r = 0.5 * (lo + hi);
    const double sag = r_rim * r_rim / (r + std::sqrt(r * r - (1 + k) * r_rim * r_rim));
    (sag > r / (1 + e) ? lo : hi) = r;
  }
  const double vertex_z = r / (e - 1), z_rim = vertex_z + r / (1 + e);
  const double f = 300 * z_rim / r_rim;
  RigParams start = MakeSingleRig(Conic<double>{r, k}, LensKind::kPerspective, vertex_z, 30, 4.5,
                                  Pinhole<double>{f, f, 640, 512, 0}, truth.image_width,
                                  truth.image_height);
  return start;
}

// A telecentric camera declared with a perspective lens, 7 photos of one board in one sector
// (as Mei's fold 2 with the perspective variant): the free camera walks off (seeds 2 and 3: tz to
// 93 mm, the tilt to 27 deg) and the solve is refused as diverged, as it was before the
// non-central part was decided (noncentral: free). With noncentral: auto the calibration says
// the non-central solve failed, holds the start's pose (the central model) and predicts 4 new
// photos of the sector within 3% of the true model's RMS.
TEST(CalibSingleNonCentral, DivergedNonCentralSolveLeavesTheCentralModel) {
  const RigParams truth = TelecentricTruth();
  const RigParams start = PerspectiveStartOf(truth);
  for (unsigned seed : {2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    EXPECT_THROW(CalibrateAndScore(truth, start, "free", seed), CalibrationError);
    const Scored run = CalibrateAndScore(truth, start, "auto", seed);
    const NonCentralDecision& decision = run.result.solve.noncentral;
    EXPECT_TRUE(decision.tested);
    EXPECT_FALSE(decision.decided);
    EXPECT_NE(decision.failure.find("diverged"), std::string::npos) << decision.failure;
    EXPECT_EQ(decision.fit, nullptr);
    // The central model: mirror1_pose held at the start's, not among the estimated parameters.
    for (int k = 0; k < 5; ++k) {
      EXPECT_EQ(run.result.estimate.rig.mirror1_pose[k], start.mirror1_pose[k]);
    }
    for (const std::string& name : run.result.estimate.names) {
      EXPECT_EQ(name.rfind("mirror1.r", 0) == 0 || name.rfind("mirror1.t", 0) == 0, false) << name;
    }
    EXPECT_LT(run.held_out_rms, 1.03 * run.true_held_out_rms);
    // Said in the notes and in the single mirror's summary.
    bool noted = false;
    for (const std::string& note : run.result.solve.notes) {
      noted |= note.find("non-central part (mirror1_pose) not determined") != std::string::npos;
    }
    EXPECT_TRUE(noted);
    const std::string text = SingleMirrorText(SummariseSingleMirror(run.result));
    EXPECT_NE(text.find("the non-central fit failed"), std::string::npos) << text;
  }
}

// A perspective camera really off its hyperboloid's far focus (0.3, -0.2, 0.5 mm; tilt 0.2 deg),
// 7 photos: the photos decide the departure for seeds 3 and 4 (chi^2 19.8, 63.2 against 13.0),
// not for seeds 1, 2, 5 (5.5, 9.1, 3.7 against 19.5, 13.0, 6.6), where the central model stands.
// Either way the tilt and offset reported (the kept fit's, or the non-central fit's under the
// central model) hold the truth within 3 sigma wherever they are given a sigma (a coordinate
// named not determined has none).
TEST(CalibSingleNonCentral, OffsetReportedWithAnHonestSigmaEitherWay) {
  const RigParams truth = PerspectiveTruth();
  const RigParams start = StartOf(truth, -2.0, {780, 780, 630, 490, 0});
  const double true_tilt = std::hypot(truth.mirror1_pose[0], truth.mirror1_pose[1]);
  int undecided = 0, decided = 0, checked = 0;
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Scored run = CalibrateAndScore(truth, start, "auto", seed, /*size_prior=*/true);
    const NonCentralDecision& decision = run.result.solve.noncentral;
    ASSERT_TRUE(decision.tested);
    ASSERT_TRUE(decision.failure.empty()) << decision.failure;
    const SingleMirrorSummary s = SummariseSingleMirror(run.result);
    // The reported (tilt, offset) and sigmas: the kept fit's, or the non-central fit's.
    const bool kept = decision.decided;
    (kept ? decided : undecided) += 1;
    ASSERT_TRUE(kept || (s.central_kept && s.has_fit));
    const double tilt = kept ? s.axis_tilt_rad : s.fit_axis_tilt_rad;
    const double tilt_sigma = kept ? s.axis_tilt_sigma_rad : s.fit_axis_tilt_sigma_rad;
    ASSERT_TRUE(kept ? s.has_offset : s.fit_has_offset);
    const Eigen::Vector3d offset = kept ? s.offset_mm : s.fit_offset_mm;
    const Eigen::Vector3d sigma = kept ? s.offset_sigma_mm : s.fit_offset_sigma_mm;
    // The truth's offset of the camera from the far focus, in M1.
    SingleMirrorSummary true_summary;
    {
      CalibrationResult t;
      t.estimate.rig = truth;
      true_summary = SummariseSingleMirror(t);
    }
    int compared = 0;
    if (std::isfinite(tilt_sigma)) {
      ++compared;
      EXPECT_LT(std::abs(tilt - true_tilt), 3 * tilt_sigma) << tilt << " +- " << tilt_sigma;
    }
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(sigma(k))) continue;  // named not determined: no number to check
      ++compared;
      EXPECT_LT(std::abs(offset(k) - true_summary.offset_mm(k)), 3 * sigma(k))
          << "axis " << k << ": " << offset(k) << " +- " << sigma(k) << " truth "
          << true_summary.offset_mm(k);
    }
    checked += compared;
    std::fprintf(stderr, "seed %u: %s, chi^2 %.1f (threshold %.1f), tilt %.3f +- %.3f deg "
                 "(truth %.3f), %d offset axes compared\n", seed, kept ? "kept" : "central",
                 decision.chi2, decision.threshold, tilt * 180 / M_PI, tilt_sigma * 180 / M_PI,
                 true_tilt * 180 / M_PI, compared);
  }
  EXPECT_GT(undecided, 0);
  EXPECT_GT(decided, 0);
  EXPECT_GT(checked, 0);
}

// A central camera (a paraboloid behind a telecentric lens, axes aligned) seen in 7 photos of one
// sector: the tilt's two coordinates are undetermined, so the covariance has nothing to test. The
// photos arbitrate (3-fold cross-validation, as with a public hyperbolic-mirror set whose free
// fit walked the principal point 27 px off the rim's centre with a 14 px sigma): the model kept
// is the central one (the non-central fit must predict the held-out folds better by more than
// the photos' standard error), and it predicts new photos of the sector within 3% of the true
// model's RMS.
TEST(CalibSingleNonCentral, NothingDeterminedThePhotosArbitrate) {
  RigParams truth = TelecentricTruth();
  truth.mirror1_pose = {0, 0, 0, 0, 0};
  truth.kind = ModelKind::kIdeal;
  const RigParams start = StartOf(truth, -1.0, {10.05, 10.05, 642.0, 510.0, 0});
  int checked = 0;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const Scored run = CalibrateAndScore(truth, start, "auto", seed);
    const NonCentralDecision& decision = run.result.solve.noncentral;
    ASSERT_TRUE(decision.tested);
    if (decision.dof != 0) continue;  // a coordinate determined: the Wald test's case
    ++checked;
    EXPECT_TRUE(decision.cross_validated) << "seed " << seed;
    // The non-central model is kept only where it predicted the held-out folds better by more
    // than the photos' standard error (here, a central truth: it never is).
    EXPECT_EQ(decision.decided, decision.cv_gain_px2 > decision.cv_gain_se_px2);
    EXPECT_GT(decision.cv_gain_se_px2, 0);
    EXPECT_FALSE(decision.decided) << "seed " << seed;
    EXPECT_LT(run.held_out_rms, 1.03 * run.true_held_out_rms) << "seed " << seed;
  }
  EXPECT_GT(checked, 0);
}

}  // namespace
}  // namespace omni::calib
