// The Levenberg-Marquardt loop both blurred-junction fits share (corner_refine.h
// FitBlurredJunction: one junction's edges; board_junction_fit.h: the whole blurred board around
// it). Parameters q: the corner (x, y), two edge angles, two grey levels and the blur sigma, which
// is held between 0.3 px and half the window (a blur, not the window's width).
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "detectors/common/corner_refine.h"

namespace omni::detectors {

using JunctionParams = Eigen::Matrix<double, 7, 1>;
using JunctionNormal = Eigen::Matrix<double, 7, 7>;

// Up to 30 iterations from q (cost: its cost); normal(q, &jtj, &jtr) gives the Gauss-Newton normal
// equations at q, cost_of(q) the cost (sum of squared residuals) of a trial. Returns the final
// cost; q moves to the best point found.
template <typename Normal, typename CostOf>
double JunctionLevenbergMarquardt(double half, double cost, const Normal& normal,
                                  const CostOf& cost_of, JunctionParams* q) {
  double lambda = 1e-3;
  for (int iteration = 0; iteration < 30; ++iteration) {
    JunctionNormal jtj;
    JunctionParams jtr;
    normal(*q, &jtj, &jtr);
    bool accepted = false, converged = false;
    for (int attempt = 0; attempt < 8 && !accepted; ++attempt) {
      JunctionNormal damped = jtj;
      damped.diagonal() *= 1 + lambda;
      const JunctionParams step = -damped.ldlt().solve(jtr);
      JunctionParams next = *q + step;
      next[6] = std::clamp(next[6], 0.3, 0.5 * half + 0.5);  // a blur, not the window's width
      const double next_cost = cost_of(next);
      if (next_cost < cost) {
        converged = step.head<2>().norm() < 1e-3;
        *q = next;
        cost = next_cost;
        lambda = std::max(0.1 * lambda, 1e-7);
        accepted = true;
      } else {
        lambda *= 10;
      }
    }
    if (!accepted || converged) break;
  }
  return cost;
}

// The fit at q, or nullopt where its corner left the window about `start`.
inline std::optional<JunctionFit> JunctionFitOf(const JunctionParams& q, double cost, size_t pixels,
                                                const Eigen::Vector2d& start, double half) {
  if (std::abs(q[0] - start.x()) > half || std::abs(q[1] - start.y()) > half) return std::nullopt;
  JunctionFit fit;
  fit.corner = q.head<2>();
  fit.sigma = q[6];
  fit.contrast = std::abs(q[5]);
  fit.rms = std::sqrt(cost / pixels);
  return fit;
}

}  // namespace omni::detectors
