#include "stereo/triangulation_inputs.h"

#include <cmath>
#include <random>

namespace omni::stereo {

SessionPairs PairsOfDetections(const Triangulator& triangulator, const Observations& detections) {
  SessionPairs out;
  for (int i = 0; i < static_cast<int>(detections.images.size()); ++i) {
    const auto& image = detections.images[i];
    out.image_names.push_back(image.file);
    out.observations += static_cast<long>(image.corners.size());
    const auto image_pairs = PairCorners(triangulator, i, image.corners);
    out.pairs.insert(out.pairs.end(), image_pairs.begin(), image_pairs.end());
  }
  return out;
}

SessionPairs PairsOfTruth(const Truth& truth, double noise_px, double noise_px_ring2,
                          unsigned seed) {
  SessionPairs out;
  std::mt19937 rng(seed);
  out.pairs = TruthPairs(truth, noise_px, &rng, noise_px_ring2);
  for (const auto& image : truth.images) out.image_names.push_back(image.file);
  out.observations = 2 * static_cast<long>(out.pairs.size());
  return out;
}

bool MeasuredCornerNoise(const RigParams& rig, double* sigma_px, double* sigma_px_ring2) {
  if (!rig.calibration || rig.calibration->per_mirror_rms_px.size() != 2 ||
      !(rig.calibration->per_mirror_rms_px[0] > 0) ||
      !(rig.calibration->per_mirror_rms_px[1] > 0)) {
    return false;
  }
  *sigma_px = rig.calibration->per_mirror_rms_px[0] / std::sqrt(2.0);
  *sigma_px_ring2 = rig.calibration->per_mirror_rms_px[1] / std::sqrt(2.0);
  return true;
}

}  // namespace omni::stereo
