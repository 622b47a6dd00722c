// What `calibrate` and `report` share: the solve with its progress, and the HTML report.
#pragma once

#include <string>

#include "calib/calibrate.h"
#include "io/session_file.h"
#include "model/observations.h"

namespace omni::apps {

// The calibration with its stages' lines on stderr and, on a terminal, a status line (stage,
// iteration, elapsed) below them; returns the solve's wall time in *seconds.
calib::CalibrationResult CalibrateWithProgress(const RigParams& start, const io::Session& session,
                                               const Observations& detections, double* seconds);

// The HTML report into `dir` (--report, or report's --out; --report_range_mm, --tolerances);
// prints where it is. The photos are the detections file's (io::ImagePathsOf).
void WriteReport(const calib::CalibrationResult& result, const Observations& detections,
                 const io::Session& session, const std::string& detections_path,
                 const std::string& dir, double seconds);

}  // namespace omni::apps
