// A session's sparse triangulation as `triangulate` runs it: its options (one field per flag,
// checked by the flag's name), the one call that pairs the corners, triangulates them into the
// output frame and compares them with a synthetic session's truth, and the rows and text that
// the command writes and prints. Files are read and written by the caller (io/).
#pragma once

#include <string>
#include <vector>

#include "model/observations.h"
#include "model/rig_params.h"
#include "model/triangulation.h"
#include "model/truth.h"
#include "stereo/sparse_triangulation.h"
#include "stereo/triangulation_inputs.h"

namespace omni::stereo {

// `triangulate`'s flags (docs/design.md, Conventions); each field is the flag of its name.
struct SessionTriangulationOptions {
  std::string model, detections, truth, out;  // paths; detections or truth may be empty
  double sigma_px = 1, sigma_px_ring2 = 0;
  // false: a calibrated model's measured corner noise per ring replaces the sigmas
  // (MeasuredCornerNoise): the 1 px default made sigmas ~10x those the session measured.
  bool sigma_given = false;
  bool model_covariance = false;
  std::string frame = "cam";         // cam | mirror1
  std::string method = "midpoint";   // midpoint | reprojection
  // Without detections: the truth's own pixels plus Gaussian noise (ring 2's noise_px_ring2 if
  // >= 0), seeded with `seed`; `seeds` > 0 also repeats that over seeds (SeedSpread).
  double noise_px = 0, noise_px_ring2 = -1;
  int seed = 1, seeds = 0;

  // Empty when consistent, else one line "--<flag>: expected <what>".
  std::string Check() const;
  // The triangulation's own options (Check() must pass); the sigmas as given.
  TriangulationOptions Triangulation() const;
};

// What TriangulateSession did.
struct SessionTriangulationRun {
  TriangulationOptions options;  // as used: the sigmas may be the model's measured noise
  bool measured_noise = false;   // they are
  SessionPairs pairs;
  SessionTriangulation result;
};

// Checks the model against the options: throws InputError naming options.model when
// --model_covariance asks for a covariance the model lacks; returns a warning (empty if none)
// when calibration parameters are not in the model's blocks.
std::string CheckModelFor(const Triangulator& triangulator,
                          const SessionTriangulationOptions& options);

// Pairs the corners (of `detections`, or without them the truth's pixels plus noise), triangulates
// each pair into the options' frame and, with a truth, compares them with the true corners
// (TriangulatePairs). true_rig is the truth's model (needed with frame mirror1 and a truth).
// Throws InputError when the truth's images do not match the detections', or no pair
// triangulates.
SessionTriangulationRun TriangulateSession(const Triangulator& triangulator, const RigParams& rig,
                                           const SessionTriangulationOptions& options,
                                           const Observations* detections, const Truth* truth,
                                           const RigParams* true_rig);

// The output CSV: its columns (docs/design.md, Files) and one row per triangulated point,
// labelled with its image's name.
std::vector<std::string> TriangulatedColumns();
std::vector<std::pair<std::string, std::vector<double>>> TriangulatedRows(
    const SessionTriangulationRun& run);

// The summary line (counts, method, sigmas and their source, output and frame).
std::string TriangulationSummary(const SessionTriangulationRun& run,
                                 const SessionTriangulationOptions& options);
// With a truth: the RMSE table by range beside `reference`, and with options.seeds the spread
// of the noisy experiment over the seeds (which triangulates the truth again per seed).
std::string TruthTables(const Triangulator& triangulator, const Truth& truth,
                        const SessionTriangulationRun& run,
                        const SessionTriangulationOptions& options,
                        const std::vector<ReferenceRow>& reference);

}  // namespace omni::stereo
