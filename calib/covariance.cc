#include "calib/covariance.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace omni::calib {
namespace {

constexpr int kPoseSize = 6;

// Inverse of a symmetric positive semi-definite matrix over its range (pseudo-inverse): a pose
// that its own corners cannot fix contributes nothing along its null space.
Eigen::MatrixXd PseudoInverse(const Eigen::MatrixXd& m) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(m);
  const Eigen::VectorXd& values = eig.eigenvalues();
  const double tol = std::max(values.maxCoeff(), 0.0) * 1e-14;
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(values.size());
  for (int i = 0; i < values.size(); ++i) {
    if (values(i) > tol) inv(i) = 1.0 / values(i);
  }
  return eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
}

Eigen::MatrixXd Restrict(const Eigen::MatrixXd& m, const std::vector<int>& idx) {
  Eigen::MatrixXd out(idx.size(), idx.size());
  for (size_t i = 0; i < idx.size(); ++i) {
    for (size_t j = 0; j < idx.size(); ++j) out(i, j) = m(idx[i], idx[j]);
  }
  return out;
}

}  // namespace

Eigen::MatrixXd RigSchurComplement(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                                   int n_rig) {
  const Eigen::SparseMatrix<double> jtj_sparse =
      (Eigen::SparseMatrix<double>(jacobian.transpose()) * jacobian).pruned();
  const int n = static_cast<int>(jacobian.cols());
  const int n_poses = (n - n_rig) / kPoseSize;
  // Dense blocks: A (rig x rig) and per pose B_p (rig x 6), C_p (6 x 6).
  const Eigen::MatrixXd jtj = Eigen::MatrixXd(jtj_sparse);
  Eigen::MatrixXd schur = jtj.topLeftCorner(n_rig, n_rig);
  for (int p = 0; p < n_poses; ++p) {
    const int c = n_rig + kPoseSize * p;
    const Eigen::MatrixXd b = jtj.block(0, c, n_rig, kPoseSize);
    const Eigen::MatrixXd c_inv = PseudoInverse(jtj.block(c, c, kPoseSize, kPoseSize));
    schur.noalias() -= b * c_inv * b.transpose();
  }
  return 0.5 * (schur + schur.transpose());
}

RigCovariance ComputeRigCovariance(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                                   int n_rig, const RigCovarianceOptions& options) {
  const Eigen::MatrixXd schur = RigSchurComplement(jacobian, n_rig);
  RigCovariance out;
  std::vector<bool> named(n_rig, false);

  // Jacobi scaling; a parameter no residual depends on is unobservable outright.
  Eigen::VectorXd scale(n_rig);
  for (int i = 0; i < n_rig; ++i) {
    scale(i) = schur(i, i) > 0 ? 1.0 / std::sqrt(schur(i, i)) : 0.0;
    if (scale(i) == 0) named[i] = true;
  }
  const Eigen::MatrixXd scaled = scale.asDiagonal() * schur * scale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  out.eigenvalues = eig.eigenvalues();
  const double largest = std::max(eig.eigenvalues().maxCoeff(), 0.0);
  for (int k = 0; k < n_rig; ++k) {
    if (eig.eigenvalues()(k) >= options.min_reciprocal_condition * largest) continue;
    for (int i = 0; i < n_rig; ++i) {
      if (scale(i) > 0 && std::abs(eig.eigenvectors()(i, k)) >= options.null_component) {
        named[i] = true;
      }
    }
  }

  // Invert over the rest; drop the worst parameter above its sigma bound and repeat.
  for (;;) {
    out.observable.clear();
    for (int i = 0; i < n_rig; ++i) {
      if (!named[i]) out.observable.push_back(i);
    }
    const Eigen::MatrixXd s = Restrict(scaled, out.observable);
    Eigen::MatrixXd cov_scaled = s.ldlt().solve(Eigen::MatrixXd::Identity(s.rows(), s.cols()));
    Eigen::VectorXd d(out.observable.size());
    for (size_t i = 0; i < out.observable.size(); ++i) d(i) = scale(out.observable[i]);
    out.covariance = options.variance_factor * d.asDiagonal() * cov_scaled * d.asDiagonal();
    int worst = -1;
    double worst_ratio = 1.0;
    for (size_t i = 0; i < out.observable.size(); ++i) {
      const int p = out.observable[i];
      const double sigma = std::sqrt(std::max(out.covariance(i, i), 0.0));
      double ratio = std::isfinite(sigma) ? 0.0 : HUGE_VAL;
      if (p < static_cast<int>(options.nearly_unobservable_sigma.size()) &&
          options.nearly_unobservable_sigma[p] > 0) {
        ratio = std::max(ratio, sigma / options.nearly_unobservable_sigma[p]);
      }
      if (ratio > worst_ratio) {
        worst_ratio = ratio;
        worst = p;
      }
    }
    if (worst < 0) break;
    named[worst] = true;
  }
  for (int i = 0; i < n_rig; ++i) {
    if (named[i]) out.unobservable.push_back(i);
  }
  return out;
}

}  // namespace omni::calib
