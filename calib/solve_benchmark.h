// A calibration solve timed, and its report against the true rig (bench_calibrate: the speed and
// memory targets of a session's solve, and its answer against the truth).
#pragma once

#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "model/observations.h"
#include "model/rig_params.h"
#include "model/target.h"

namespace omni::calib {

struct TimedSolve {
  CalibrationResult result;
  double wall_s = 0, cpu_s = 0;  // wall clock and process CPU time of the solve
};
TimedSolve SolveTimed(const RigParams& start, const std::vector<TargetSpec>& targets,
                      const Observations& detections, const CalibrationOptions& options);

// The report, newline-terminated: the session's images, corner observations and lip edge points
// with the solve's threads; the times, convergence and RMS; the process's peak memory (peak_mb);
// the parameter table against `truth` and TruthLine (calibration_checks.h).
std::string TimedSolveReport(const TimedSolve& solve, const Observations& detections, int images,
                             int threads, double peak_mb, const RigParams& truth);

}  // namespace omni::calib
