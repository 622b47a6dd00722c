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
//
// Considered parameters (the "consider covariance" of orbit determination): coordinates held at
// their starting value although they are not known exactly, e.g. the tangential distortion,
// held because over the rings' radii it is nearly the image of a rotation of the camera against
// the mirror bodies (freeing it lets the solve wander along that valley). A held value off by dc
// moves the estimate by dx = -S_xx^-1 S_xc dc, so with dc ~ N(0, Sigma_c) the covariance gains
// S_xx^-1 S_xc Sigma_c S_cx S_xx^-1: the sigmas stay honest about what was assumed.
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
  // Sigma of each considered column; the Jacobian has them right after the n_rig refined
  // columns (before the nuisance blocks). Empty: none.
  std::vector<double> considered_sigma;
  // Considered columns (indices among them, ascending) whose assumed covariance diag(sigma^2) is
  // first updated by the data's own information on them with the refined parameters free:
  // Sigma_post = (Sigma^-1 + S_c|x)^-1, S_c|x = S_cc - S_cx S_xx^-1 S_xc. The covariance then
  // gains S_xx^-1 S_xc Sigma_post S_cx S_xx^-1, which is the marginal covariance the refined
  // parameters would have with these columns freed under a prior of that sigma, while the
  // estimate keeps them held. Used for a profile held for want of evidence (profile: auto): the
  // data bound the profile's components they can tell from the refined parameters; the tolerance
  // stays whole along those they cannot (the power term against the axial positions). The
  // columns are replaced by the factors of Sigma_post (RigCovariance::considered_column_*).
  // Their share is in the covariance but not in the nearly-unobservable test: that asks what the
  // data determine with the held coordinates as they are.
  std::vector<int> updated_considered;
};

struct RigCovariance {
  std::vector<int> observable;    // rig parameter indices with a covariance, ascending
  std::vector<int> unobservable;  // named instead (exact null space or sigma above its bound)
  Eigen::MatrixXd covariance;     // over `observable`, scaled by the variance factor, plus the
                                  // considered parameters' share
  Eigen::MatrixXd noise_covariance;  // the same without the considered parameters' share
  // d estimate / d held value of each considered column (-S_xx^-1 S_xc), rows `observable`:
  // how a held value off by dc moves the estimate.
  Eigen::MatrixXd considered_sensitivity;
  // Per considered column: its sigma and what it is in the held coordinates (n_considered x
  // n_considered, unit columns): options.considered_sigma and the identity, except over
  // options.updated_considered, whose columns are then the factors of their Sigma_post.
  Eigen::VectorXd considered_column_sigma;
  Eigen::MatrixXd considered_column_mix;
  // The data's information on options.updated_considered's coordinates with the refined ones
  // free, S_c|x (in that order, per unit of the held coordinates squared, divided by the
  // variance factor): what the data tell of them, without the assumed sigma. Empty without them.
  Eigen::MatrixXd updated_information;
  Eigen::VectorXd eigenvalues;    // of the Jacobi-scaled Schur complement, ascending
  Eigen::MatrixXd eigenvectors;   // columns, same order (in the scaled coordinates)
};

// `jacobian`: residuals x (n_rig + n_considered + 6 * n_poses), rig columns first, then the
// considered columns, then one 6-column block per target pose (or options.nuisance_sizes);
// residuals whitened (unit-variance noise per residual up to s^2).
RigCovariance ComputeRigCovariance(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                                   int n_rig, const RigCovarianceOptions& options);

// The same from RigSchurComplement(jacobian, n_rig + n_considered, options.nuisance_sizes): the
// Schur complement over the rig and considered columns, so that one Jacobian can be analysed
// with a coordinate held or freed (a principal submatrix holds it).
RigCovariance RigCovarianceFromSchur(const Eigen::MatrixXd& schur_all, int n_rig,
                                     const RigCovarianceOptions& options);

// The Schur complement of `schur`'s last row and column, a nuisance parameter shared by the
// nuisance blocks RigSchurComplement eliminates one by one (a single mirror's edge circle radius,
// which couples its points' azimuths), so kept as a front column and eliminated here, densely:
// S_aa - S_ab S_ab^T / S_bb. *coupling = S_ab / S_bb, *information = S_bb (the last dropped, with
// no coupling, where S_bb is not positive). The parameter's variance is then
// 1 / S_bb + coupling^T Cov coupling, Cov the inverse of the result (block inverse).
Eigen::MatrixXd EliminateLastColumn(const Eigen::MatrixXd& schur, Eigen::VectorXd* coupling,
                                    double* information);

// Schur complement of the pose blocks in J^T J.
Eigen::MatrixXd RigSchurComplement(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                                   int n_rig, const std::vector<int>& nuisance_sizes = {});

}  // namespace omni::calib
