// Assembly tolerances: (1) does a built (calibrated) rig meet them, given the calibration's
// uncertainty, and (2) what would parts machined and assembled to them do to the images, before
// anything is built (Monte Carlo over rigs drawn within the tolerances).
//
// Quantities checked, per mirror body (DESIGN.md §2 misalignment parameters):
//   decentre  = |(tx, ty)|   mm      tilt = |(rx, ry)|   rad      axial = |tz|   mm
// and for the reflex plane in mirror 1's body: tilt = |(rx, ry)| rad, offset = |dz| mm.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "model/rig_params.h"

namespace omni::design {

// Limits (>= 0; a negative value means "not toleranced").
struct BodyTolerance {
  double decentre_mm = -1, tilt_rad = -1, axial_mm = -1;
};
struct ToleranceSpec {
  BodyTolerance mirror[2];
  double reflex_tilt_rad = -1, reflex_dz_mm = -1;
  double confidence_sigmas = 2.0;  // a verdict must hold at value +- this many sigma
};

enum class Verdict { kPass, kFail, kUndecided };
const char* VerdictName(Verdict verdict);

struct ToleranceCheck {
  std::string name;             // e.g. mirror1.decentre
  std::string unit;             // mm | rad
  double value = 0;             // the magnitude measured
  std::optional<double> sigma;  // first-order sigma of the magnitude (calibrated models only)
  double limit = 0;
  Verdict verdict = Verdict::kUndecided;
};

// Checks a model against the spec. With a covariance (rig.calibration, parameter names like
// mirror1.tx, reflex.rx) a verdict is PASS only if value + k*sigma <= limit, FAIL only if
// value - k*sigma > limit, and UNDECIDED otherwise (more data would decide it). Without a
// covariance the verdict compares the value alone (and says so by an empty sigma).
std::vector<ToleranceCheck> CheckTolerances(const RigParams& rig, const ToleranceSpec& spec);

// The image effect of the tolerances: `samples` rigs are drawn uniformly within the limits
// (decentre uniform in a disc, tilt uniform in a disc, axial and dz uniform in +-limit, random
// directions) around `nominal`; each projects a grid of points at horizontal range `range_mm`
// that the nominal rig sees in both rings. Shifts are pixel distances from the nominal pixels.
struct ImageEffect {
  int points = 0, samples = 0;
  double p50_px[2] = {0, 0}, p95_px[2] = {0, 0}, max_px[2] = {0, 0};  // [ring of mirror 1, 2]
  double lost_fraction = 0;  // points no longer valid in a drawn rig
};
// `progress` (may be empty) is called after each drawn rig with (done, samples).
ImageEffect SimulateImageEffect(const RigParams& nominal, const ToleranceSpec& spec, int samples,
                                double range_mm, unsigned seed,
                                const std::function<void(int, int)>& progress = {});

}  // namespace omni::design
