// A real lens on the fast path (issue #16, item 4): the misaligned big rig photographed through a
// lens with barrel distortion (sample_configs/big_rig_real_lens.yaml: dist_k1 -0.12, dist_k2
// 0.05, dist_p1 3e-4, dist_p2 -2e-4; the rings' outer edge 1.3% in), realistic_scene.yaml's 24
// images (chessboards and tag grids at 0.3-2.5 m, each target at its own range), exact corners
// from ComputeTruth plus Gaussian noise, lip edge points like the detector's with small
// independent noise and a systematic per-edge offset common to every image (as
// calib_demo_fastpath_test). Solved from the ideal design with zero distortion, what a user has
// (10 / 18 px off at 1 m): the distortion must be found, every misalignment parameter and
// dist_k1, dist_k2 must land within 3 sigma of the truth, the model must project like the true
// one in mirror 1's body, and the output must say that dist_k3 is held and that the camera
// frame's pointing is uncertain.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "calib/calibrate.h"
#include "model/model_compare.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

struct RealLensRun {
  RigParams truth;
  CalibrationResult result;
  ProjectionDifference ideal, plain, in_mirror1;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();  // of the camera frame, best aligned
};

RigParams RealLensRig() {
  return io::ReadModelFile(std::string(OMNI_SOURCE_DIR) + "/sample_configs/big_rig_real_lens.yaml");
}

double SigmaOf(const CalibrationResult& r, const std::string& name) {
  for (size_t i = 0; i < r.estimate.names.size(); ++i) {
    if (r.estimate.names[i] == name) return r.uncertainty.sigma(i);
  }
  return NAN;
}

bool HasNote(const CalibrationResult& r, const std::string& start) {
  for (const auto& note : r.solve.notes) {
    if (note.rfind(start, 0) == 0) return true;
  }
  return false;
}

// realistic_scene through `lens_rig` with `noise_px` per axis on the corners, solved from the
// ideal design with the default options; checks what holds at any noise level.
RealLensRun SolveRealLens(const RigParams& lens_rig, double noise_px) {
  RealLensRun run;
  testing::SyntheticSession session;
  run.truth = testing::MakeSceneSession(
      lens_rig, std::string(OMNI_SOURCE_DIR) + "/sample_configs/realistic_scene.yaml", &session);
  const RigParams& truth = run.truth;
  Observations detections = testing::NoisyDetections(session, noise_px, 17);
  testing::AddLipDetections(truth, 0.03, 19, &detections, 360);
  testing::AddSystematicLipOffsets(truth, 0.03, 23, &detections);

  CalibrationOptions options;  // camera, distortion, both poses, reflex; p1, p2 held, considered
  // Exact quadrics by construction, and this test's subject is not the mirrors' profile: the
  // profile stays out (calib_profile_test.cc covers it; freed, it trades with fx and tz).
  options.profile = "off";
  options.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  const RigParams ideal = testing::IdealRig();
  const auto t0 = std::chrono::steady_clock::now();
  run.result = Calibrate(ideal, session.targets, detections, options);
  std::fprintf(stderr, "solve %.2f s wall (%d threads)\n%s",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
               options.solver.threads, ResultTable(run.result, &truth).c_str());

  const RigModel true_model(truth);
  run.ideal = CompareProjections(true_model, RigModel(ideal), 1000);
  run.plain = CompareProjections(true_model, RigModel(run.result.estimate.rig), 1000);
  CompareProjectionsUpToRotation(true_model, RigModel(run.result.estimate.rig), 1000,
                                 &run.rotation);
  run.in_mirror1 = CompareProjectionsInMirror1(true_model, RigModel(run.result.estimate.rig), 1000);
  std::fprintf(stderr,
               "projection difference at 1 m over %d band points (ring 1 / ring 2): ideal start "
               "%.3f / %.3f px; calibrated in C %.4f / %.4f px (frame rotation %.4f deg), in "
               "mirror 1's body %.4f / %.4f px\n",
               run.plain.points, run.ideal.rms_px[0], run.ideal.rms_px[1], run.plain.rms_px[0],
               run.plain.rms_px[1], run.rotation.norm() * 180 / M_PI, run.in_mirror1.rms_px[0],
               run.in_mirror1.rms_px[1]);

  const CalibrationResult& result = run.result;
  // The start is far: a solve that stayed there, or lost the lens, fails everything below.
  EXPECT_GT(run.ideal.rms_px[0], 5.0);
  EXPECT_TRUE(result.solve.converged);
  EXPECT_TRUE(result.residuals.rejected.empty());  // exact pixels + Gaussian noise: no outliers
  // 2-D residual RMS of corners with noise_px per axis: sqrt(2) * noise_px less the fitted share.
  for (int m = 0; m < 2; ++m) {
    EXPECT_NEAR(result.residuals.per_mirror_rms_px[m], std::sqrt(2.0) * noise_px,
                0.2 * std::sqrt(2.0) * noise_px);
  }
  int n_checked = 0;
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    const std::string& name = result.estimate.names[i];
    if (!testing::IsMisalignment(name) && name != "dist_k1" && name != "dist_k2") continue;
    ++n_checked;
    const double t = testing::TruthValue(truth, name);
    EXPECT_LT(std::abs(result.estimate.values(i) - t), 3 * result.uncertainty.sigma(i))
        << name << " = " << result.estimate.values(i) << " truth " << t << " sigma "
        << result.uncertainty.sigma(i);
  }
  EXPECT_EQ(n_checked, 15);  // 13 misalignment parameters, dist_k1, dist_k2: none unobservable
  // The rings reach r = 0.28 (normalised): dist_k3 is held and the output says why; and it says
  // that the camera frame's pointing is uncertain (the camera-rotation valley).
  EXPECT_TRUE(HasNote(result, "dist_k3 held at 0"));
  EXPECT_TRUE(HasNote(result, "camera pointing"));
  EXPECT_EQ(result.estimate.rig.distortion[kDistK3], 0.0);
  return run;
}

// The lens at 0.05 px corner noise: in mirror 1's body the calibrated model projects like
// the true one to <= 0.1 px at 1 m. In C the held dist_p1, dist_p2 turn the frame along the
// camera-rotation valley (~0.1 deg), within the pointing sigma the output states.
// Measured: all within 1.47 sigma (reflex.dz; dist_k1 -0.28, dist_k2 +0.70); residual RMS
// 0.0694 / 0.0710 px; M1 0.090 / 0.047 px (ideal start 10.0 / 18.4 px); in C 0.43 / 0.22 px
// after a 0.108 deg frame rotation, pointing sigma 0.136 deg; solve 5-7 s wall on 2 busy cores.
TEST(CalibRealLens, IdealStartFindsTheLens) {
  const RealLensRun run = SolveRealLens(RealLensRig(), 0.05);
  EXPECT_LE(run.in_mirror1.rms_px[0], 0.1);
  EXPECT_LE(run.in_mirror1.rms_px[1], 0.1);
  const double pointing_sigma = std::max(SigmaOf(run.result, "mirror1.rx"),
                                         SigmaOf(run.result, "mirror1.ry"));
  EXPECT_LT(run.rotation.norm(), 3 * pointing_sigma);
}

// At 0.1 px corner noise the same holds to 3 sigma; dist_k2 (sigma 0.085, 0.25 px at the rings'
// edge) stays determined. Measured: all within 1.42 sigma; M1 0.105 / 0.056 px.
TEST(CalibRealLens, IdealStartFindsTheLensAtATenthOfAPixel) {
  SolveRealLens(RealLensRig(), 0.1);
}

// A lens without decentring distortion: the held dist_p1 = dist_p2 = 0 are exact, so the
// camera frame is no longer turned along the valley and the model projects like the true one
// in C too. Measured: C 0.099 / 0.051 px (0.021 deg), M1 0.086 / 0.045 px; all within 1.45 sigma.
TEST(CalibRealLens, LensWithoutTangentialDistortionProjectsInTheCameraFrame) {
  RigParams lens = RealLensRig();
  lens.distortion[kDistP1] = lens.distortion[kDistP2] = 0;
  const RealLensRun run = SolveRealLens(lens, 0.05);
  EXPECT_LE(run.plain.rms_px[0], 0.15);
  EXPECT_LE(run.plain.rms_px[1], 0.15);
  EXPECT_LE(run.in_mirror1.rms_px[0], 0.1);
  EXPECT_LE(run.in_mirror1.rms_px[1], 0.1);
}

}  // namespace
}  // namespace omni::calib
