// Evidence of one photo simulated from a known rig, for the check's tests (check.h): matches of
// points on a room's walls projected by the rig as it is now, with pixel noise, and its lip
// edges with noise and, if asked, a detector's bias.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include <Eigen/Core>

#include "health/check.h"
#include "model/lip.h"
#include "model/rig_model.h"

namespace omni::health {

// One image's evidence from `now`: `n_points` wall points (a 6 x 6 m room, floor -1.2 m,
// ceiling 1.8 m) seen in both rings, pixel noise `match_sigma` per coordinate; the three lip
// edges the detector finds on these rigs with `lip_sigma` across them, each point moved across
// its edge by `lip_bias` (px, outward) of its path and its circle's azimuth if given (a
// detector's bias: the same in every photo).
inline ImageEvidence Simulate(
    const RigParams& now, int n_points, double match_sigma, double lip_sigma, unsigned seed,
    const std::function<double(LipPath, double)>& lip_bias = nullptr) {
  const RigModel model(now);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1, 1);
  std::normal_distribution<double> noise(0, 1);
  ImageEvidence e;
  while (static_cast<int>(e.matches.size()) < n_points) {
    const double a = M_PI * uniform(rng);
    const Eigen::Vector2d dir(std::cos(a), std::sin(a));
    const double r = 3000 / std::max(std::abs(dir.x()), std::abs(dir.y()));
    const Eigen::Vector3d point(r * dir.x(), r * dir.y(), 300 + 1500 * uniform(rng));
    const auto p1 = model.Project(point, Mirror::kOne), p2 = model.Project(point, Mirror::kTwo);
    if (!p1 || !p2) continue;
    RingMatch m;
    m.pixel1 = *p1 + match_sigma * Eigen::Vector2d(noise(rng), noise(rng));
    m.pixel2 = *p2 + match_sigma * Eigen::Vector2d(noise(rng), noise(rng));
    m.azimuth = a;
    m.elevation = std::atan2(point.z(), r);
    e.matches.push_back(m);
  }
  const Eigen::Vector2d centre(now.camera[kCx], now.camera[kCy]);
  for (LipPath path : {LipPath::kDirect, LipPath::kViaMirror1, LipPath::kViaMirror2}) {
    LipEdgeObservation edge;
    edge.mirror = LipOwner(path);
    edge.path = path;
    edge.circle = LipCircle::kOuter;
    for (int k = 0; k < 360; ++k) {
      const auto p = ProjectLipPoint(model, path, LipCircle::kOuter, k * M_PI / 180);
      if (!p) continue;
      const double bias = lip_bias ? lip_bias(path, k * M_PI / 180) : 0;
      edge.points.push_back(*p + (bias + lip_sigma * noise(rng)) * (*p - centre).normalized());
    }
    e.lips.push_back(edge);
  }
  return e;
}

}  // namespace omni::health
