#include "model/camera.h"

#include <Eigen/Dense>

namespace omni {

bool Undistort(const RadTan<double>& dist, const Eigen::Vector2d& distorted,
               Eigen::Vector2d* undistorted) {
  if (dist.IsZero()) {
    *undistorted = distorted;
    return true;
  }
  Eigen::Vector2d xy = distorted;
  for (int iter = 0; iter < 50; ++iter) {
    const double x = xy.x(), y = xy.y();
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (dist.dist_k1 + r2 * (dist.dist_k2 + r2 * dist.dist_k3));
    const double d_radial_d_r2 = dist.dist_k1 + r2 * (2 * dist.dist_k2 + 3 * r2 * dist.dist_k3);
    const Eigen::Vector2d residual = dist.Distort(xy) - distorted;
    Eigen::Matrix2d jac;
    jac(0, 0) = radial + 2 * x * x * d_radial_d_r2 + 2 * dist.dist_p1 * y + 6 * dist.dist_p2 * x;
    jac(0, 1) = 2 * x * y * d_radial_d_r2 + 2 * dist.dist_p1 * x + 2 * dist.dist_p2 * y;
    jac(1, 0) = 2 * x * y * d_radial_d_r2 + 2 * dist.dist_p1 * x + 2 * dist.dist_p2 * y;
    jac(1, 1) = radial + 2 * y * y * d_radial_d_r2 + 6 * dist.dist_p1 * y + 2 * dist.dist_p2 * x;
    const Eigen::Vector2d step = jac.partialPivLu().solve(residual);
    xy -= step;
    if (step.norm() < 1e-15 * (1 + xy.norm())) {
      *undistorted = xy;
      return (dist.Distort(xy) - distorted).norm() < 1e-12;
    }
  }
  *undistorted = xy;
  return (dist.Distort(xy) - distorted).norm() < 1e-12;
}

}  // namespace omni
