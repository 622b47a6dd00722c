// The paper's sparse triangulation experiment (tab:rmse_triangulation_experiment): corners seen
// in both rings are paired, triangulated (model/triangulation.h) and compared with the true
// corners of a synthetic session (model/truth.h; the `omnistereo-truth/1` file that `render`
// writes, read by io/truth_file.h), per horizontal range.
#pragma once

#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/observations.h"
#include "model/triangulation.h"
#include "model/truth.h"

namespace omni::stereo {

// One corner seen in both rings of one image.
struct CornerPair {
  int image = 0;  // index into the detections' (or truth's) images
  int target = 0, id = 0;
  Eigen::Vector2d pixel1 = Eigen::Vector2d::Zero(), pixel2 = Eigen::Vector2d::Zero();
};

// Pairs the mirror-1 and mirror-2 observations of one image by (target, id). Where a target
// occurs several times in the image (the RMSE scene shows each board 4 times, 90 deg apart), the
// pairs whose rays' azimuths agree best win (greedy): a point's two rays lie in (nearly, for a
// misaligned rig) the same azimuth plane through the axis, and unlike the rays' gap this still
// holds with a model far from the rig (the ideal model of a misaligned rig, case (b), from 0.5 m
// out). Candidates more than kMaxPairAzimuthDifference apart, or whose common-perpendicular gap
// exceeds max_gap_fraction of the triangulated range, are dropped. Each observation is used once.
// A calibrated model keeps every true pair down to 0.25 m; the ideal model of big_rig_misaligned
// keeps none there (azimuths 4.1-5.6 deg apart, gaps 7-10% of the range).
constexpr double kMaxPairAzimuthDifference = 5 * M_PI / 180;
std::vector<CornerPair> PairCorners(const Triangulator& triangulator, int image,
                                    const std::vector<CornerObservation>& corners,
                                    double max_gap_fraction = 0.05);

// The scene's distinct horizontal placement ranges (boards within 10% merged), as the range
// bins of the experiment's table.
std::vector<double> RangeBins(const Truth& truth);

// Corner pairs straight from the truth pixels, with Gaussian noise of noise_px per coordinate
// (for running the experiment without a detector); ring 2 (mirror 2) gets noise_px_ring2 if
// >= 0, else noise_px (the detector's error differs between the rings).
std::vector<CornerPair> TruthPairs(const Truth& truth, double noise_px, std::mt19937* rng,
                                   double noise_px_ring2 = -1);

// One triangulated corner compared with the truth.
struct CornerError {
  double range_bin_mm = 0;  // the ring (horizontal range of its board) it belongs to
  Eigen::Vector3d error = Eigen::Vector3d::Zero();  // estimate - truth, mm
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // as triangulated (pixel + model)
  // What the detector got wrong: detected - true pixels (u1, v1, u2, v2), and what is needed to
  // re-weigh the covariance with the measured pixel error: A = d point / d pixels and the
  // covariance's model part.
  Eigen::Vector4d pixel_error = Eigen::Vector4d::Zero();
  Eigen::Matrix<double, 3, 4> jacobian_px = Eigen::Matrix<double, 3, 4>::Zero();
  Eigen::Matrix3d model_covariance = Eigen::Matrix3d::Zero();
};

// Matches a triangulated corner to its true corner by its PIXELS (independent of the model and
// the triangulation): the same image and corner id whose true pixels are nearest, within 3 px in
// both rings. The target index is not used: a detector cannot tell apart chessboards of the same
// rows x cols (the RMSE scene has one 4x5 board per range, differing only in square size), so
// its target indices need not be the scene's. The range bin is the horizontal range of the board's placement,
// rounded to the nearest of range_bins_mm (RangeBins(truth)).
std::optional<CornerError> CompareWithTruth(const Truth& truth,
                                            const std::vector<double>& range_bins_mm,
                                            const CornerPair& pair,
                                            const TriangulatedPoint& estimate);

struct RangeRow {
  double range_mm = 0;
  int points = 0;
  double rmse_mm = 0;        // sqrt(mean |e|^2)
  double sd_mm = 0;          // standard deviation of |e|
  double mean_sigma_mm = 0;  // mean predicted sqrt(trace Sigma)
  double mean_nees = 0;      // mean e^T Sigma^-1 e (3 if the covariance is right)
  // The detector's corner error in this range bin, per ring: RMS per pixel coordinate
  // (sqrt(mean (du^2 + dv^2) / 2)), and the mean NEES with Sigma re-computed from those
  // measured sigmas (A diag(s1^2, s1^2, s2^2, s2^2) A^T + the model part): the test of the
  // propagation itself, whatever sigma_px the user assumed.
  double pixel_rms_px[2] = {0, 0};
  double mean_nees_measured = 0;
};
std::vector<RangeRow> RangeTable(const std::vector<CornerError>& errors);

// The table as text (range m, RMSE, SD, points, the reference's RMSE and SD (ReferenceRow,
// model/truth.h) or "-", mean sigma,
// NEES, the per-ring pixel RMS and the NEES at those).
std::string FormatRangeTable(const std::vector<RangeRow>& rows,
                             const std::vector<ReferenceRow>& reference = {});

// The experiment without a detector, repeated: the truth's pixels plus Gaussian noise (noise_px
// in ring 1, noise_px_ring2 in ring 2) over `seeds` seeds, triangulated with `options`. Per
// range: the RMSE that first-order propagation predicts at those sigmas (sqrt of the mean
// trace of A diag(s1^2, s1^2, s2^2, s2^2) A^T at the true pixels), the RMSE over all seeds, and
// how one run's RMSE spreads over the seeds (5th, 50th, 95th percentile): how far a table from
// one image (the paper's 80 points per range) may land from the expected value by chance.
struct SeedSpreadRow {
  double range_mm = 0;
  int points = 0;  // per seed
  double predicted_rmse_mm = 0, rmse_mm = 0;
  double p05_mm = 0, p50_mm = 0, p95_mm = 0;
};
std::vector<SeedSpreadRow> SeedSpread(const Triangulator& triangulator, const Truth& truth,
                                      double noise_px, double noise_px_ring2, int seeds,
                                      unsigned first_seed, const TriangulationOptions& options);
// The spread as text, with the reference's RMSE by range.
std::string FormatSeedSpread(const std::vector<SeedSpreadRow>& rows,
                             const std::vector<ReferenceRow>& reference = {});

// A triangulated point moved rigidly into the frame that `to_from_cam` maps C to: the point,
// both covariances and the pixel Jacobian re-expressed.
TriangulatedPoint Moved(TriangulatedPoint p, const Pose<double>& to_from_cam);

// The frames of a session's triangulation: the output frame from C (C itself, or mirror 1's
// body M1 of `rig`) and, for the comparison with a truth, the estimate's C taken to the true
// rig's C (identity in C; through M1 when the output is in M1, since the estimated and the true
// M1 are the same body: `true_rig` is then required).
struct OutputFrames {
  Pose<double> out_from_cam;
  Pose<double> true_cam_from_cam;
};
OutputFrames FramesOf(const RigParams& rig, ReferenceBody reference, const RigParams* true_rig);

// Every pair triangulated with `options` and expressed in frames.out_from_cam's frame; with a
// truth, each compared with its true corner in the true rig's C (CompareWithTruth).
struct TriangulatedPair {
  CornerPair pair;
  TriangulatedPoint point;  // in the output frame
};
struct SessionTriangulation {
  std::vector<TriangulatedPair> points;
  long failed = 0;                  // pairs that did not triangulate
  long unmatched = 0;               // with a truth: points without a true corner
  std::vector<CornerError> errors;  // with a truth
};
SessionTriangulation TriangulatePairs(const Triangulator& triangulator,
                                      const std::vector<CornerPair>& pairs,
                                      const TriangulationOptions& options,
                                      const OutputFrames& frames, const Truth* truth);

}  // namespace omni::stereo
