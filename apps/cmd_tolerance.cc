// `omnistereo tolerance --model M --config tolerances.yaml`: checks a (calibrated) rig against
// assembly tolerances, with a verdict that respects the calibration's uncertainty, and simulates
// what parts within the tolerances do to the images (design/tolerance.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/progress.h"
#include "design/decide_photos.h"
#include "design/tolerance.h"
#include "design/tolerance_file.h"
#include "io/model_file.h"

namespace omni::apps {
int RunTolerance() {
  if (FLAGS_model.empty() || FLAGS_config.empty()) {
    throw io::InputError("--model and --config (an omnistereo-tolerances/1 file) are required");
  }
  const RigParams rig = io::ReadModelFile(FLAGS_model);
  const design::ToleranceFile tol = design::ReadToleranceFile(FLAGS_config);

  const auto checks = design::CheckTolerances(rig, tol.spec);
  const bool calibrated = rig.calibration && !rig.calibration->covariance.empty();
  std::printf("Tolerance check of %s (%s; verdicts at +-%.1f sigma)\n", FLAGS_model.c_str(),
              calibrated ? "calibrated, with covariance" : "no covariance: values alone",
              tol.spec.confidence_sigmas);
  // The quantity column as wide as its longest name (18 for the camera-frame checks alone).
  int width = 18;
  for (const auto& c : checks) width = std::max(width, static_cast<int>(c.name.size()));
  std::printf("  %-*s %12s %10s %10s  %s\n", width, "quantity", "value", "sigma", "limit", "verdict");
  int counts[3] = {0, 0, 0};
  for (const auto& c : checks) {
    const bool deg = c.unit == "rad";
    const double k = deg ? 180.0 / M_PI : 1.0;
    const char* unit = deg ? "deg" : "mm";
    char sigma[32] = "-";
    if (c.sigma) std::snprintf(sigma, sizeof sigma, "%.4f", *c.sigma * k);
    std::printf("  %-*s %8.4f %-3s %10s %10.4f  %s\n", width, c.name.c_str(), c.value * k, unit, sigma,
                c.limit * k, design::VerdictName(c.verdict));
    ++counts[static_cast<int>(c.verdict)];
    for (const std::string& line : {design::Correction(c), design::RotationValleyNote(c), c.note}) {
      if (!line.empty()) std::printf("    %s\n", line.c_str());
    }
  }
  std::printf("  %d pass, %d fail, %d undecided%s\n", counts[0], counts[1], counts[2],
              counts[2] ? " (undecided: the limit lies within the uncertainty; more calibration "
                          "images at more ranges and azimuths would decide)"
                        : "");
  // For each undecided check of a calibrated model: the photos that would decide it, simulated
  // through the model (design/decide_photos.h).
  if (calibrated && counts[2] > 0) {
    const auto photos = design::PhotosThatDecide(rig, checks, tol.spec.confidence_sigmas);
    if (!photos.empty()) {
      std::printf("Photos that would decide (simulated through the calibrated model, each chosen to "
                  "lower the sigma most; first order):\n");
    }
    for (const design::DecidingPhotos& d : photos) {
      const auto check = std::find_if(checks.begin(), checks.end(),
                                      [&](const auto& c) { return c.name == d.check; });
      const bool deg = check->unit == "rad";
      std::printf("  %s: %s\n", d.check.c_str(),
                  d.Describe(deg ? "deg" : "mm", deg ? 180.0 / M_PI : 1.0).c_str());
    }
  }
  if (tol.simulate_samples > 0) {
    design::ImageEffect effect;
    {
      ProgressLine progress("tolerance Monte Carlo, rig", tol.simulate_samples);
      effect = design::SimulateImageEffect(rig, tol.spec, tol.simulate_samples,
                                           tol.simulate_range_mm, tol.simulate_seed,
                                           [&](int, int) { progress.Done(""); });
    }
    std::printf("Image effect of parts within these tolerances (%d rigs, %d points at %.0f mm seen "
                "in both rings):\n",
                effect.samples, effect.points, tol.simulate_range_mm);
    for (int m = 0; m < 2; ++m) {
      std::printf("  ring of mirror %d: pixel shift median %.2f px, 95%% %.2f px, max %.2f px\n",
                  m + 1, effect.p50_px[m], effect.p95_px[m], effect.max_px[m]);
    }
    std::printf("  points leaving the image or the ring: %.2f%%\n", 100 * effect.lost_fraction);
  }
  // How good the machining must be: random smooth profiles of a reference size on both mirrors
  // (the effects are linear in it), against 0.1 px at 1 m and 1% range error at 2 m.
  constexpr double kReferencePvMm = 0.010;
  const design::ProfileSensitivity sens =
      design::SimulateProfileSensitivity(rig, kReferencePvMm, 40, tol.simulate_seed);
  std::printf("Machining (%d random smooth profiles of %.0f um peak-to-valley on both mirrors):\n",
              sens.samples, 1000 * sens.pv_mm);
  for (int m = 0; m < 2; ++m) {
    std::printf("  ring of mirror %d: pixel shift 95%% %.2f px at 1 m\n", m + 1,
                sens.p95_shift_px_1m[m]);
  }
  std::printf("  range error of triangulated points at 2 m: 95%% %.2f%%\n",
              100 * sens.p95_range_error_2m);
  const double for_px = std::min(sens.PvFor(0.1, sens.p95_shift_px_1m[0]),
                                 sens.PvFor(0.1, sens.p95_shift_px_1m[1]));
  std::printf("  for 0.1 px at 1 m uncalibrated: profile <= %.2f um peak-to-valley; for 1%% range "
              "error at 2 m: <= %.1f um (a calibration that refines the profile relaxes both)\n",
              1000 * for_px, 1000 * sens.PvFor(0.01, sens.p95_range_error_2m));
  return 0;
}

}  // namespace omni::apps
