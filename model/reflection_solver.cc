#include "model/reflection_solver.h"

#include <cmath>

namespace omni {

bool IdealReflectionSeed(const HyperboloidSheet<double>& sheet, const Eigen::Vector3d& b,
                         Eigen::Vector2d* xy) {
  const Eigen::Vector3d focus(0, 0, sheet.PrimaryFocusZ());
  const Eigen::Vector3d dir = b - focus;
  double t = 0;
  if (!(dir.squaredNorm() > 0) || !sheet.IntersectRay(focus, dir, &t, 0.0)) return false;
  const Eigen::Vector3d p = focus + t * dir;
  *xy = p.head<2>();
  return std::isfinite(xy->x()) && std::isfinite(xy->y());
}

bool IdealReflectionSeed(const ConicSheet<double>& sheet, const Eigen::Vector3d& b,
                         Eigen::Vector2d* xy) {
  const Eigen::Vector3d focus(0, 0, sheet.SeedPointZ());
  const Eigen::Vector3d dir = b - focus;
  double t = 0;
  if (!(dir.squaredNorm() > 0) || !sheet.IntersectRay(focus, dir, &t, 0.0)) return false;
  *xy = (focus + t * dir).head<2>();
  return std::isfinite(xy->x()) && std::isfinite(xy->y());
}

bool SolveReflectionPointDouble(const MirrorSurface<double>& sheet, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b, const ReflectionSolverOptions& options,
                                Eigen::Vector2d* xy, ReflectionSolverInfo* info,
                                bool a_at_infinity) {
  info->converged = false;
  info->iterations = 0;
  Eigen::Vector2d grad, grad_trial;
  Eigen::Matrix2d hess, hess_trial;
  const double max_radius2 = options.max_radius * options.max_radius;
  if (!PathLengthGradient(sheet, a, b, xy->x(), xy->y(), &grad, &hess, a_at_infinity)) return false;
  for (int iter = 0; iter < options.max_iterations; ++iter) {
    const double det = hess(0, 0) * hess(1, 1) - hess(0, 1) * hess(1, 0);
    if (!(std::abs(det) > 0) || !std::isfinite(det)) return false;
    Eigen::Vector2d step(-(hess(1, 1) * grad(0) - hess(0, 1) * grad(1)) / det,
                         -(-hess(1, 0) * grad(0) + hess(0, 0) * grad(1)) / det);
    double length = step.norm();
    if (!std::isfinite(length)) return false;
    ++info->iterations;
    if (length <= options.step_tolerance) {  // in the region of quadratic convergence
      *xy += step;
      info->converged = true;
      return xy->squaredNorm() <= max_radius2;
    }
    if (length > options.max_step) {
      step *= options.max_step / length;
      length = options.max_step;
    }
    // Backtracking on the merit |grad|^2; Newton's direction decreases it at rate -2 |grad|^2.
    const double merit = grad.squaredNorm();
    double t = 1;
    bool accepted = false;
    for (int k = 0; k < 40; ++k, t *= 0.5) {
      const Eigen::Vector2d trial = *xy + t * step;
      if (trial.squaredNorm() > max_radius2) continue;
      if (!PathLengthGradient(sheet, a, b, trial.x(), trial.y(), &grad_trial, &hess_trial,
                              a_at_infinity)) {
        continue;
      }
      // Close to the solution the merit sits at rounding level and need not decrease: take the
      // full Newton step there.
      if (grad_trial.squaredNorm() <= (1 - 1e-4 * t) * merit || (t == 1 && length < 1e-6)) {
        accepted = true;
        break;
      }
    }
    if (!accepted) return false;
    *xy += t * step;
    grad = grad_trial;
    hess = hess_trial;
  }
  return false;
}

}  // namespace omni
