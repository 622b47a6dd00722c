#include "calib/solve_benchmark.h"

#include <chrono>
#include <ctime>

#include "calib/calibration_checks.h"
#include "io/text_append.h"

namespace omni::calib {

TimedSolve SolveTimed(const RigParams& start, const std::vector<TargetSpec>& targets,
                      const Observations& detections, const CalibrationOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  TimedSolve out;
  out.result = Calibrate(start, targets, detections, options);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  return out;
}

std::string TimedSolveReport(const TimedSolve& solve, const Observations& detections, int images,
                             int threads, double peak_mb, const RigParams& truth) {
  size_t corners = 0, lip_points = 0;
  for (const auto& image : detections.images) {
    corners += image.corners.size();
    for (const auto& lip : image.lips) lip_points += lip.points.size();
  }
  const CalibrationResult& result = solve.result;
  std::string out;
  io::AppendFormat(&out, "images %d, corner observations %zu, lip edge points %zu, threads %d\n",
                   images, corners, lip_points, threads);
  io::AppendFormat(&out, "solve: %.2f s wall, %.2f s CPU (%s), rms %.3f px over %d observations\n",
                   solve.wall_s, solve.cpu_s, result.solve.converged ? "converged" : "NOT converged",
                   result.residuals.rms_px, result.residuals.n_observations);
  io::AppendFormat(&out, "peak memory (whole process, max RSS): %.1f MB\n", peak_mb);
  return out + ResultTable(result, &truth) + TruthLine(result, truth);
}

}  // namespace omni::calib
