// What a session's triangulation starts from (`triangulate`): its corner pairs, from detections
// or from a synthetic session's true pixels, and the pixel noise a calibrated model measured.
#pragma once

#include <string>
#include <vector>

#include "model/observations.h"
#include "model/rig_params.h"
#include "model/triangulation.h"
#include "model/truth.h"
#include "stereo/sparse_triangulation.h"

namespace omni::stereo {

struct SessionPairs {
  std::vector<CornerPair> pairs;
  std::vector<std::string> image_names;  // by CornerPair::image
  long observations = 0;                 // corner observations the pairs were made from
};

// Every image's corners paired by the model (PairCorners).
SessionPairs PairsOfDetections(const Triangulator& triangulator, const Observations& detections);
// The truth's own pixels plus Gaussian noise (TruthPairs, std::mt19937 seeded with `seed`).
SessionPairs PairsOfTruth(const Truth& truth, double noise_px, double noise_px_ring2,
                          unsigned seed);

// A calibrated model's measured corner noise per ring, as the pixel sigma per axis (its residual
// RMS is sqrt(2) sigma per axis): true and *sigma_px, *sigma_px_ring2 set when the model has
// both rings' residual RMS, else false and nothing set.
bool MeasuredCornerNoise(const RigParams& rig, double* sigma_px, double* sigma_px_ring2);

}  // namespace omni::stereo
