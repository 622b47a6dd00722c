// The rig parameters' covariance from the Jacobian of the final solve, and which parameters the
// data cannot determine (calibration step 4).
//
// With residuals in pixels and i.i.d. noise of variance s^2, cov(x) = s^2 (J^T J)^-1. The target
// poses are nuisance parameters: each touches only its own residuals, so J^T J is the arrow
// matrix [[A, B], [B^T, C]] with C block diagonal (one 6x6 block per placement), and the rig
// block of its inverse is the inverse of the Schur complement S = A - B C^-1 B^T. S is analysed
// after Jacobi scaling (unit diagonal, so mm, rad and px compare): eigenvectors whose eigenvalue
// is below `min_reciprocal_condition` times the largest span the (numerically) unobservable
// directions, and every parameter with a large component in one is named. The covariance is the
// pseudo-inverse of S (the marginal covariance on the observable subspace; nearly unobservable
// parameters are NOT held fixed, so they widen the sigma of the parameters they trade with); a
// parameter whose sigma exceeds its `nearly_unobservable_sigma` bound is named too and left out
// of the reported covariance.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace omni::calib {

struct RigCovarianceOptions {
  double variance_factor = 1.0;            // s^2 (px^2 per unit-weight residual)
  double min_reciprocal_condition = 1e-12; // on the Jacobi-scaled Schur complement
  double null_component = 0.2;             // |eigenvector component| that implicates a parameter
  std::vector<double> nearly_unobservable_sigma;  // per rig parameter; empty: no bound
  // Column count of each nuisance block after the rig columns (target poses: 6, lip edge point
  // azimuths: 1); empty: all target poses.
  std::vector<int> nuisance_sizes;
};

struct RigCovariance {
  std::vector<int> observable;    // rig parameter indices with a covariance, ascending
  std::vector<int> unobservable;  // named instead (exact null space or sigma above its bound)
  Eigen::MatrixXd covariance;     // over `observable`, scaled by the variance factor
  Eigen::VectorXd eigenvalues;    // of the Jacobi-scaled Schur complement, ascending
  Eigen::MatrixXd eigenvectors;   // columns, same order (in the scaled coordinates)
};

// `jacobian`: residuals x (n_rig + 6 * n_poses), rig columns first, then one 6-column block per
// target pose; residuals whitened (unit-variance noise per residual up to s^2).
RigCovariance ComputeRigCovariance(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                                   int n_rig, const RigCovarianceOptions& options);

// Schur complement of the pose blocks in J^T J (exposed for tests).
Eigen::MatrixXd RigSchurComplement(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                                   int n_rig, const std::vector<int>& nuisance_sizes = {});

}  // namespace omni::calib
