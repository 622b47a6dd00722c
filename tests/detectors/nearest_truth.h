// The wrong-id oracle the detector tests share: a detected corner is right only if the nearest
// true corner in its ring (ComputeTruth) is the same target and id.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "synthetic/scene.h"

namespace omni::testing {

// The true corner seen via `mirror` nearest to `pixel`, and its distance; nullptr if none is
// seen in that ring.
inline const synthetic::CornerTruth* NearestTruth(const std::vector<synthetic::CornerTruth>& truth,
                                                  Mirror mirror, const Eigen::Vector2d& pixel,
                                                  double* distance) {
  const int m = MirrorIndex(mirror) - 1;
  const synthetic::CornerTruth* nearest = nullptr;
  *distance = 1e9;
  for (const auto& t : truth) {
    if (!t.pixel[m]) continue;
    const double d = (pixel - *t.pixel[m]).norm();
    if (d < *distance) {
      *distance = d;
      nearest = &t;
    }
  }
  return nearest;
}

}  // namespace omni::testing
