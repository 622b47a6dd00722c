// The calibration report: DIR/index.html with its images beside it, self-contained
// (no external URL, no script), viewable offline in any browser. What a user needs to judge a
// calibration at a glance: the verdict and residuals per ring against the noise, the parameter
// table with sigmas, where the corners were (coverage), where the model is trustworthy
// (projection uncertainty maps from the covariance), the strongest correlations, the left-out
// corners, and advice in words computed from the data. Plots are gnuplot's (pngcairo, as mrcal
// draws its own), images over the frames OpenCV's.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "design/tolerance.h"
#include "model/observations.h"
#include "model/target.h"

namespace omni::report {

struct ReportInput {
  const calib::CalibrationResult* result = nullptr;
  const Observations* observations = nullptr;  // what the calibration was given
  std::vector<TargetSpec> targets;
  // Per observation image, the frame's path (resolved), for the drawings over it; a missing or
  // unreadable one gives a dark canvas instead.
  std::vector<std::string> image_paths;
  std::string session;        // shown in the title
  double solve_seconds = 0;
  double range_mm = 2000;     // the second range of the uncertainty maps (1 m is always shown)
  // Assembly tolerance verdicts of the calibrated rig (calibrate --tolerances FILE); shown when
  // not empty.
  std::vector<design::ToleranceCheck> tolerances;
  // What the report is drawing now, for a terminal's status line; may be empty.
  std::function<void(const std::string&)> status;
};

// Writes DIR/index.html and its images (DIR is created if missing) and returns the index's
// path. Throws InputError naming DIR if it cannot be written. Without gnuplot on the PATH
// (scripts/install_deps.sh installs it) each plot is replaced by a line saying so.
std::string WriteReport(const std::string& dir, const ReportInput& input);

// The advice the report gives, one sentence each, computed from the result and the
// observations (advice.cc); empty when nothing stands out.
std::vector<std::string> Advice(const ReportInput& input);

}  // namespace omni::report
