// Machined mirrors (issue 40) through the calibration, fast path (exact corner pixels of the true
// profiled rig plus 0.05 px noise, lips at 0.1 px): a 10 um peak-to-valley "power" error on both
// mirrors. Without the profile in the model (profile: off, the calibration before issue 40) it
// hides in the mirrors' heights and the focal length with residuals at the noise: the axial
// positions end many sigmas off. Freed (what `auto` does where the corners cover the mirror's
// radii), with the machining tolerance as prior, every misalignment is within 3 sigma and points
// held in mirror 1's body at 1 m project within the predicted uncertainty of the true rig.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <thread>

#include "calib/calibrate.h"
#include "calib/projection_uncertainty.h"
#include "model/model_compare.h"
#include "tests/calib/calib_test_util.h"

namespace omni::calib {
namespace {

using testing::IdealRig;
using testing::MisalignedRig;

// The misaligned sample rig with a smooth profile error on both mirrors: P1(w) is r^2 over the
// used radii, half its peak-to-valley in sag_p1; a little P2 and astigmatism besides.
RigParams ProfiledTruth(double pv_mm) {
  RigParams truth = MisalignedRig();
  truth.profile1 = DefaultProfileShape(truth, Mirror::kOne);
  truth.profile2 = DefaultProfileShape(truth, Mirror::kTwo);
  truth.mirror1_profile = {0.5 * pv_mm, -0.1 * pv_mm, 0, 0, 0.05 * pv_mm, 0};
  truth.mirror2_profile = {0.5 * pv_mm, 0.1 * pv_mm, 0, 0, 0, -0.05 * pv_mm};
  return truth;
}

testing::SyntheticSession NearAndFarSession(const RigParams& truth) {
  synthetic::RandomPlacement random;
  random.images = 20;
  random.targets_min = 2;
  random.targets_max = 3;
  random.range_min_mm = 400;
  random.range_max_mm = 2500;
  random.max_tilt_rad = 0.35;
  random.seed = 23;
  return testing::MakeSession(truth, random,
                              {testing::Chessboard(6, 8, 40.0), testing::Chessboard(5, 7, 60.0),
                               testing::Chessboard(7, 9, 30.0)});
}

struct Outcome {
  double worst_sigmas = 0;  // the largest |error| / sigma over the misalignments
  std::string worst;
  double m1_rms_px[2] = {0, 0};  // points in mirror 1's body at 1 m
  double predicted_px[2] = {0, 0};  // their predicted uncertainty
  CalibrationResult result;
};

Outcome RunCalibration(const RigParams& truth, const std::string& profile) {
  const auto session = NearAndFarSession(truth);
  CalibrationOptions options;
  options.profile = profile;
  // The lips are seen directly at their machined heights: they fix the mirrors' axial
  // positions, which targets alone cannot tell from a profile's power term.
  Observations detections = testing::NoisyDetections(session, 0.05, 3);
  testing::AddLipDetections(truth, 0.1, 4, &detections, 180);
  Outcome out;
  out.result = Calibrate(IdealRig(), session.targets, detections, options);
  std::fprintf(stderr, "profile: %s\n%s", profile.c_str(), ResultTable(out.result, &truth).c_str());
  for (size_t i = 0; i < out.result.estimate.names.size(); ++i) {
    const std::string& name = out.result.estimate.names[i];
    if (!testing::IsMisalignment(name) || name.find(".sag_") != std::string::npos) continue;
    const double z = std::abs(out.result.estimate.values(i) - testing::TruthValue(truth, name)) /
                     out.result.uncertainty.sigma(i);
    if (z > out.worst_sigmas) out.worst_sigmas = z, out.worst = name;
  }
  const ProjectionDifference d =
      CompareProjectionsInMirror1(RigModel(truth), RigModel(out.result.estimate.rig), 1000.0);
  out.m1_rms_px[0] = d.rms_px[0];
  out.m1_rms_px[1] = d.rms_px[1];
  const ProjectionUncertainty predicted = PredictProjectionUncertainty(out.result, 1000.0);
  out.predicted_px[0] = predicted.in_mirror1_px[0];
  out.predicted_px[1] = predicted.in_mirror1_px[1];
  std::fprintf(stderr,
               "profile %s: worst misalignment %s at %.2f sigma; in M1 at 1 m %.3f / %.3f px, "
               "predicted %.3f / %.3f px\n",
               profile.c_str(), out.worst.c_str(), out.worst_sigmas, d.rms_px[0], d.rms_px[1],
               predicted.in_mirror1_px[0], predicted.in_mirror1_px[1]);
  return out;
}

// The profile out of the model (the calibration before issue 40): confidently wrong.
TEST(CalibProfile, HeldOutOfTheModelTheProfileErrorIsConfidentlyWrong) {
  const Outcome off = RunCalibration(ProfiledTruth(0.010), "off");
  EXPECT_GT(off.worst_sigmas, 5.0) << "the profile error no longer biases the old model";
  EXPECT_GT(off.m1_rms_px[0], off.predicted_px[0]);
}

// Freed (the default where the corners cover the radii): the misalignments hold, and the
// predicted uncertainty of points in M1 covers the model's real error. A profile's power term
// trades with the mirrors' axial positions (and the focal length): targets and lips fit both at
// the noise, so M1's axial place against the camera is as uncertain as the machining tolerance
// makes it, and the session says so instead of being wrong.
TEST(CalibProfile, FreedTheMisalignmentsHoldAndTheUncertaintyIsHonest) {
  const Outcome out = RunCalibration(ProfiledTruth(0.010), "free");
  EXPECT_TRUE(out.result.residuals.profile[0].freed);
  EXPECT_TRUE(out.result.residuals.profile[1].freed);
  EXPECT_TRUE(out.result.estimate.rig.profile1.present);
  EXPECT_LT(out.worst_sigmas, 3.0) << out.worst;
  for (int m = 0; m < 2; ++m) EXPECT_LT(out.m1_rms_px[m], 2.5 * out.predicted_px[m]) << m;
}

// profile: auto frees a profile on evidence only (issue 49): exact quadrics leave no radial
// pattern, so it stays held, and the points in mirror 1's body at 1 m are as good as with the
// profile out of the model (within 20%); freed by default they came out nearly twice as far off.
TEST(CalibProfile, AutoOnExactMirrorsKeepsThePrecisionOfOff) {
  const Outcome off = RunCalibration(MisalignedRig(), "off");
  const Outcome automatic = RunCalibration(MisalignedRig(), "auto");
  for (int m = 0; m < 2; ++m) {
    EXPECT_FALSE(automatic.result.residuals.profile[m].freed) << m;
    EXPECT_TRUE(automatic.result.residuals.profile[m].updated) << m;
    EXPECT_LT(automatic.m1_rms_px[m], 1.2 * off.m1_rms_px[m]) << m;
  }
  EXPECT_LT(automatic.worst_sigmas, 3.0) << automatic.worst;
  // Held, its tolerance is in the sigmas only as far as the data leave it open (updated by
  // them), so nothing that profile: off determines is named not determined (the tolerance
  // considered whole named the demo's axial positions so), and the note says what it adds.
  for (const auto& u : automatic.result.uncertainty.unobservable) {
    bool off_too = false;
    for (const auto& v : off.result.uncertainty.unobservable) off_too |= v.name == u.name;
    EXPECT_TRUE(off_too) << u.name << " not determined under auto, determined under off";
  }
  bool said = false;
  for (const std::string& note : automatic.result.solve.notes) {
    said |= note.find("held profiles' tolerance") != std::string::npos &&
            note.find("mirror1.tz sigma") != std::string::npos;
  }
  EXPECT_TRUE(said);
}

// On machined mirrors (10 um PV of power on both, five times the stated 2 um tolerance's sigma
// per term) auto stays honest whatever it decides: every misalignment within 3 sigma.
TEST(CalibProfile, AutoOnMachinedMirrorsStaysHonest) {
  const Outcome out = RunCalibration(ProfiledTruth(0.010), "auto");
  for (int m = 0; m < 2; ++m) {
    const ProfileDecision& d = out.result.residuals.profile[m];
    std::fprintf(stderr, "mirror %d: freed %d, pattern chi2 per band %.2f (1%% level %.2f)\n",
                 m + 1, d.freed, d.pattern_chi2_before, d.evidence_threshold);
  }
  EXPECT_LT(out.worst_sigmas, 3.0) << out.worst;
  // Points in mirror 1's body at 1 m: the held profile's error is within the predicted
  // uncertainty (with the updated tolerance's direct effect through its combinations).
  for (int m = 0; m < 2; ++m) EXPECT_LT(out.m1_rms_px[m], 2.0 * out.predicted_px[m]) << m;
}

TEST(CalibProfile, ExactQuadricsStayWithinTheirSigmas) {
  const Outcome out = RunCalibration(MisalignedRig(), "free");
  EXPECT_LT(out.worst_sigmas, 3.0) << out.worst;
  for (int m = 0; m < 2; ++m) EXPECT_LT(out.m1_rms_px[m], 2.5 * out.predicted_px[m]) << m;
}

// Turning marks (a 4 um PV ripple of 6 mm period on mirror 1, exact quadric otherwise): no
// profile term takes them, so the corners' radial residuals along the mirror's radius keep a
// pattern, and the session says so. Printed: the pattern with the profile held and freed.
TEST(CalibProfile, ARippleShowsInTheRadialPattern) {
  RigParams truth = MisalignedRig();
  truth.profile1 = DefaultProfileShape(truth, Mirror::kOne);
  truth.profile1.ripple_amplitude = 0.002;
  truth.profile1.ripple_period = 6.0;
  for (const char* mode : {"hold", "auto"}) {
    const Outcome out = RunCalibration(truth, mode);
    const ProfileDecision& d = out.result.residuals.profile[0];
    for (size_t b = 0; b < d.pattern_after.size(); ++b) {
      std::fprintf(stderr, "%s: r %.1f-%.1f mm  n %4d  mean radial residual %+.4f +- %.4f px\n",
                   mode, d.pattern_after[b].r_lo, d.pattern_after[b].r_hi, d.pattern_after[b].count,
                   d.pattern_after[b].mean_px, d.pattern_after[b].sem_px);
    }
    EXPECT_GT(d.pattern_chi2_after, 4.0) << mode;
    bool said = false;
    for (const auto& note : out.result.solve.notes)
      said |= note.find("mirror 1's profile") != std::string::npos;
    EXPECT_TRUE(said) << mode;
  }
  // The exact quadrics leave no pattern.
  const Outcome exact = RunCalibration(MisalignedRig(), "hold");
  EXPECT_LT(exact.result.residuals.profile[0].pattern_chi2_after, 4.0);
  EXPECT_LT(exact.result.residuals.profile[1].pattern_chi2_after, 4.0);
}

// Monte Carlo over pixel noise and the prior (issue 40's acceptance): the small clean session of
// calib_montecarlo_test.cc with profiled mirrors (10 um PV power on both), the profile freed. The
// prior's mean is the starting model's profile, drawn per solve from N(truth, profile_sigma_mm^2)
// per term, as a machinist's tolerance describes the parts: then the errors' spread over the
// solves is what the predicted sigma (noise_sigma: pixel noise and prior, without the considered
// parameters) claims. With N solves a spread/predicted ratio has sd ~1/sqrt(2N) (11% at N = 40),
// so each parameter is held to [0.65, 1.5] and the RMS of the ratios over the misalignments and
// the camera to within 20% of 1. MC_SOLVES overrides N.
TEST(CalibProfile, MonteCarloConfirmsTheSigmasWithTheProfileFreed) {
  testing::SyntheticSession session;
  RigParams truth_full = MisalignedRig();
  truth_full.distortion[kDistP1] = truth_full.distortion[kDistP2] = 0;
  const RigParams profiled = ProfiledTruth(0.010);
  truth_full.profile1 = profiled.profile1;
  truth_full.profile2 = profiled.profile2;
  truth_full.mirror1_profile = profiled.mirror1_profile;
  truth_full.mirror2_profile = profiled.mirror2_profile;
  const RigParams truth = testing::MakeSceneSession(
      truth_full, std::string(OMNI_SOURCE_DIR) + "/sample_configs/small_clean_scene.yaml", &session);
  const int solves = std::getenv("MC_SOLVES") ? std::atoi(std::getenv("MC_SOLVES")) : 40;
  // The default 2 um tolerance per term: drawn at 5 um the starting profile is ~10 um off at
  // the rim, where the lips' via-mirror images move by pixels, and the rounds reject the lips
  // before the freed profile has fitted them (docs/experiments.md 2026-11-27, issue 40).
  const double sigma_mm = 0.002;
  std::vector<CalibrationResult> results(solves);
  std::vector<std::string> failures(solves);
  auto run = [&](int first, int step) {
    for (int k = first; k < solves; k += step) {
      Observations detections = testing::NoisyDetections(session, 0.1, 1000 + k);
      testing::AddLipDetections(truth, 0.03, 5000 + k, &detections, 90);
      RigParams start = truth;
      std::mt19937 rng(9000 + k);
      std::normal_distribution<double> draw(0.0, sigma_mm);
      for (double& c : start.mirror1_profile) c += draw(rng);
      for (double& c : start.mirror2_profile) c += draw(rng);
      CalibrationOptions options;
      options.profile = "free";
      options.profile_sigma_mm = sigma_mm;
      options.solver.threads = 1;
      if (std::getenv("MC_VERBOSE")) {
        options.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
      }
      try {
        results[k] = Calibrate(start, session.targets, detections, options);
      } catch (const CalibrationError& e) {
        failures[k] = e.what();
      }
    }
  };
  std::thread worker(run, 1, 2);
  run(0, 2);
  worker.join();
  for (int k = 0; k < solves; ++k) EXPECT_TRUE(failures[k].empty()) << "solve " << k << ": " << failures[k];
  std::map<std::string, std::vector<double>> errors, sigmas;
  for (const auto& r : results) {
    for (size_t i = 0; i < r.estimate.names.size(); ++i) {
      errors[r.estimate.names[i]].push_back(r.estimate.values(i) -
                                            testing::TruthValue(truth, r.estimate.names[i]));
      sigmas[r.estimate.names[i]].push_back(r.uncertainty.noise_sigma(i));
    }
  }
  double sum_ratio2 = 0;
  int compared = 0;
  for (const auto& [name, e] : errors) {
    double rms = 0, predicted = 0;
    for (double x : e) rms += x * x / e.size();
    for (double s : sigmas[name]) predicted += s / e.size();
    const double ratio = std::sqrt(rms) / predicted;
    std::fprintf(stderr, "%-16s n %3zu  RMS error %.6g  predicted %.6g  ratio %.3f\n", name.c_str(),
                 e.size(), std::sqrt(rms), predicted, ratio);
    // dist_k1's bound depends on the radii reached (covariance.cc): it may be named in a few.
    if (testing::IsMisalignment(name)) {
      EXPECT_EQ(e.size(), static_cast<size_t>(solves)) << name << " was named unobservable";
    }
    EXPECT_GT(ratio, 0.65) << name;
    EXPECT_LT(ratio, 1.5) << name;
    if (name.find(".sag_") != std::string::npos) continue;
    sum_ratio2 += ratio * ratio;
    ++compared;
  }
  const double rms_ratio = std::sqrt(sum_ratio2 / compared);
  std::fprintf(stderr, "RMS of the ratios over %d misalignment and camera parameters: %.3f\n",
               compared, rms_ratio);
  EXPECT_NEAR(rms_ratio, 1.0, 0.2);
}

}  // namespace
}  // namespace omni::calib
