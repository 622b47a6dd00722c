// The covariance checked by Monte Carlo on a real session (bench_calibrate montecarlo; the
// sigmas within 20% on a realistic-preset session). From the reference calibration R0 of the
// session's detections: each synthetic session keeps exactly the observations R0 used, each
// replaced by its value under R0 (ExactOf) plus white Gaussian noise of the group's measured
// sigma (Noisy): corners projected from R0's target poses with R0's per-ring sigma per axis, lip
// edge points moved to the nearest point of R0's band edge (model/lip.h DistanceToLipEdgeImage)
// with R0's lip RMS across the edge as the per-axis sigma. Each is solved from R0's rig. Per
// parameter: the spread of the solves against the mean predicted pixel-noise sigma
// (CalibrationResult::noise_sigma, the covariance without the considered parameters' share: the
// synthetic noise is white and unbiased, p1 = p2 = 0 held exactly), and the bias; then the
// spread's chi^2 against the solves' mean noise covariance (pseudo-inverse of its Jacobi-scaled
// form, so the camera-rotation valley's near-gauge counts by its own eigenvalue): mean
// d^T C^+ d over the solves, ~rank if the covariance's shape is right too.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "model/observations.h"
#include "model/target.h"

namespace omni::calib {

// R0's exact value of every observation it used: corners from its target poses, lip points on
// its band edges (points farther than 1 px from it, which R0 could have left out as outliers,
// left out too).
struct ExactSession {
  Observations detections;  // exact pixels; lips keep their edge labels
  int corners[2] = {0, 0}, lip_points = 0, lip_dropped = 0;
};
ExactSession ExactOf(const CalibrationResult& r0, const std::vector<TargetSpec>& targets,
                     const Observations& detections);

// The exact session plus white Gaussian noise (per axis: corner_sigma_px per ring, lip_sigma_px),
// from std::mt19937(seed).
Observations Noisy(const ExactSession& exact, const double corner_sigma_px[2],
                   double lip_sigma_px, unsigned seed);

// R0's measured noise, which the synthetic sessions get: each ring's corners' sigma per axis
// (its variance component), the lips' RMS across the edge (0 without lips).
struct MeasuredNoise {
  double corner_sigma_px[2] = {0, 0};
  double lip_sigma_px = 0;
};
MeasuredNoise MeasuredNoiseOf(const CalibrationResult& r0, bool use_lips);
// R0 described (`seconds`: its solve's wall time): RMS and counts, then each variance component's
// sigma, correlation factor and weight. Newline-terminated.
std::string ReferenceText(const CalibrationResult& r0, double seconds);
// The synthetic sessions described: corners per ring, lip points and their noise, the lip points
// left out, and how the solves run. Newline-terminated.
std::string SyntheticSessionsText(const ExactSession& exact, const MeasuredNoise& noise,
                                  int solves, int workers);

struct MonteCarloSolves {
  std::vector<CalibrationResult> results;  // per solve (empty where it failed)
  std::vector<std::string> errors;         // per solve, what() where it threw
  std::vector<double> seconds;             // per solve, wall
  double wall_s = 0;                       // all of them
};
// `solves` noisy sessions (seeds 1000 + k) solved from R0's rig with `options` (one thread per
// solve: options.solver.threads as given), `workers` at a time.
MonteCarloSolves SolveNoisySessions(const CalibrationResult& r0,
                                    const std::vector<TargetSpec>& targets,
                                    const ExactSession& exact, const double corner_sigma_px[2],
                                    double lip_sigma_px, const CalibrationOptions& options,
                                    int solves, int workers);

// The solves against R0's prediction as text (the parameters observable in most solves; those
// that failed or found others observable named and left out): per parameter the spread, the
// predicted sigma, their ratio and the bias; the chi^2 of the spread against the mean noise
// covariance per eigen-direction. *used: the solves used (the summary stops after saying so
// when fewer than 2).
std::string MonteCarloSummary(const CalibrationResult& r0, const MonteCarloSolves& solves,
                              int* used);

// The whole check on a real session (bench_calibrate montecarlo): R0 solved from `start` with
// `options` (timed) and described (ReferenceText); the synthetic sessions at R0's measured noise
// described and solved, one thread each, `workers` at a time; MonteCarloSummary. Each part's text
// goes to print() as it is known (R0's long before the solves'). Returns the solves used.
int MonteCarloCheck(const RigParams& start, const std::vector<TargetSpec>& targets,
                    const Observations& detections, CalibrationOptions options, int solves,
                    int workers, const std::function<void(const std::string&)>& print);

}  // namespace omni::calib
