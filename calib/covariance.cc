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
                                   int n_rig, const std::vector<int>& nuisance_sizes) {
  // Sparse-aware: with one phi block per lip edge point there are tens of thousands of nuisance
  // columns, so J^T J is never formed densely. A = J_r^T J_r (J_r dense, rows x n_rig); per
  // nuisance block b: B_b = J_r^T J_b, C_b = J_b^T J_b.
  const Eigen::SparseMatrix<double> jcm(jacobian);  // column major
  const int n = static_cast<int>(jacobian.cols());
  const Eigen::MatrixXd j_rig = Eigen::MatrixXd(jcm.leftCols(n_rig));
  Eigen::MatrixXd schur = j_rig.transpose() * j_rig;
  std::vector<int> sizes = nuisance_sizes;
  if (sizes.empty()) sizes.assign((n - n_rig) / kPoseSize, kPoseSize);
  int c = n_rig;
  for (int size : sizes) {
    const Eigen::SparseMatrix<double> j_b = jcm.middleCols(c, size);
    c += size;
    if (j_b.nonZeros() == 0) continue;
    const Eigen::MatrixXd b = j_rig.transpose() * j_b;  // dense x sparse: O(nonzeros of J_b)
    const Eigen::MatrixXd c_b = Eigen::MatrixXd(Eigen::SparseMatrix<double>(j_b.transpose() * j_b));
    schur.noalias() -= b * PseudoInverse(c_b) * b.transpose();
  }
  return 0.5 * (schur + schur.transpose());
}

Eigen::MatrixXd EliminateLastColumn(const Eigen::MatrixXd& schur, Eigen::VectorXd* coupling,
                                    double* information) {
  const int n = static_cast<int>(schur.rows()) - 1;
  *information = schur(n, n);
  const Eigen::VectorXd s_ab = schur.col(n).head(n);
  Eigen::MatrixXd out = schur.topLeftCorner(n, n);
  *coupling = Eigen::VectorXd::Zero(n);
  if (!(*information > 0)) return out;
  *coupling = s_ab / *information;
  out.noalias() -= s_ab * coupling->transpose();
  return 0.5 * (out + out.transpose());
}

RigCovariance ComputeRigCovariance(const Eigen::SparseMatrix<double, Eigen::RowMajor>& jacobian,
                                   int n_rig, const RigCovarianceOptions& options) {
  const int n_considered = static_cast<int>(options.considered_sigma.size());
  return RigCovarianceFromSchur(
      RigSchurComplement(jacobian, n_rig + n_considered, options.nuisance_sizes), n_rig, options);
}

RigCovariance RigCovarianceFromSchur(const Eigen::MatrixXd& schur_all, int n_rig,
                                     const RigCovarianceOptions& options) {
  const int n_considered = static_cast<int>(options.considered_sigma.size());
  const Eigen::MatrixXd schur = schur_all.topLeftCorner(n_rig, n_rig);
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
  out.eigenvectors = eig.eigenvectors();
  const double largest = std::max(eig.eigenvalues().maxCoeff(), 0.0);
  for (int k = 0; k < n_rig; ++k) {
    if (eig.eigenvalues()(k) >= options.min_reciprocal_condition * largest) continue;
    for (int i = 0; i < n_rig; ++i) {
      if (scale(i) > 0 && std::abs(eig.eigenvectors()(i, k)) >= options.null_component) {
        named[i] = true;
      }
    }
  }

  // The marginal covariance: the inverse over the observable subspace (the exact null
  // directions removed), so a nearly unobservable parameter still widens the sigma of those it
  // trades with instead of silently pinning them.
  std::vector<int> measured;
  for (int i = 0; i < n_rig; ++i) {
    if (scale(i) > 0) measured.push_back(i);
  }
  const Eigen::MatrixXd s = Restrict(scaled, measured);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_s(s);
  const double tol = options.min_reciprocal_condition * std::max(eig_s.eigenvalues().maxCoeff(), 0.0);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(s.rows());
  for (int k = 0; k < s.rows(); ++k) {
    if (eig_s.eigenvalues()(k) >= tol && eig_s.eigenvalues()(k) > 0) inv(k) = 1.0 / eig_s.eigenvalues()(k);
  }
  const Eigen::MatrixXd cov_scaled =
      eig_s.eigenvectors() * inv.asDiagonal() * eig_s.eigenvectors().transpose();
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(n_rig, n_rig);
  for (size_t a = 0; a < measured.size(); ++a) {
    for (size_t b = 0; b < measured.size(); ++b) {
      full(measured[a], measured[b]) = options.variance_factor * scale(measured[a]) *
                                       cov_scaled(a, b) * scale(measured[b]);
    }
  }
  // The considered parameters' share: full / variance_factor is S_xx^-1 (on the measured
  // subspace), so the estimate's sensitivity to them is -full / variance_factor * S_xc.
  Eigen::MatrixXd considered_share = Eigen::MatrixXd::Zero(n_rig, n_rig);
  Eigen::MatrixXd sensitivity = Eigen::MatrixXd::Zero(n_rig, n_considered);
  out.considered_column_sigma =
      Eigen::Map<const Eigen::VectorXd>(options.considered_sigma.data(), n_considered);
  out.considered_column_mix = Eigen::MatrixXd::Identity(n_considered, n_considered);
  if (n_considered > 0 && options.variance_factor > 0) {
    sensitivity =
        -(full / options.variance_factor) * schur_all.topRightCorner(n_rig, n_considered);
    const std::vector<int>& g = options.updated_considered;
    if (!g.empty()) {
      // S_c|x over the group, then Sigma_post = D (I + D S_c|x D)^-1 D with D = diag(sigma):
      // factored as L L^T, L = D U Lambda^-1/2 (A = U Lambda U^T); each column of L is one new
      // considered column (its norm the sigma, its direction the mix).
      const int k = static_cast<int>(g.size());
      Eigen::MatrixXd s_cc(k, k), s_xc(n_rig, k);
      Eigen::VectorXd d(k);
      for (int a = 0; a < k; ++a) {
        d(a) = options.considered_sigma[g[a]];
        s_xc.col(a) = schur_all.col(n_rig + g[a]).head(n_rig);
        for (int b = 0; b < k; ++b) s_cc(a, b) = schur_all(n_rig + g[a], n_rig + g[b]);
      }
      const Eigen::MatrixXd s_c_given_x =
          (s_cc - s_xc.transpose() * (full / options.variance_factor) * s_xc) /
          options.variance_factor;
      out.updated_information = 0.5 * (s_c_given_x + s_c_given_x.transpose());
      Eigen::MatrixXd a = d.asDiagonal() * s_c_given_x * d.asDiagonal();
      a = 0.5 * (a + a.transpose());
      a.diagonal().array() += 1.0;
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_a(a);
      const Eigen::MatrixXd l =
          d.asDiagonal() * eig_a.eigenvectors() *
          eig_a.eigenvalues().cwiseMax(1.0).cwiseInverse().cwiseSqrt().asDiagonal();
      const Eigen::MatrixXd s_g = sensitivity(Eigen::all, g);
      for (int a2 = 0; a2 < k; ++a2) {
        const double norm = l.col(a2).norm();
        out.considered_column_sigma(g[a2]) = norm;
        Eigen::VectorXd mix = Eigen::VectorXd::Zero(n_considered);
        for (int b = 0; b < k; ++b) mix(g[b]) = norm > 0 ? l(b, a2) / norm : 0.0;
        out.considered_column_mix.col(g[a2]) = mix;
        sensitivity.col(g[a2]) = norm > 0 ? Eigen::VectorXd(s_g * l.col(a2) / norm)
                                          : Eigen::VectorXd::Zero(n_rig);
      }
    }
    considered_share = sensitivity *
                       out.considered_column_sigma.array().square().matrix().asDiagonal() *
                       sensitivity.transpose();
  }
  // Nearly unobservable: a sigma beyond the parameter's bound says nothing, so it is named. The
  // test is on what the data tell with the held coordinates as they are (the pixel noise and
  // the detector biases' share), not on an updated column's share: a profile held for want of
  // evidence leaves its power term open along the axial positions and the focal length, and
  // that is said in their sigmas (and a note), not by calling parameters the data determine
  // (as with profile: off) not determined.
  Eigen::VectorXd updated_share = Eigen::VectorXd::Zero(n_rig);
  for (int c : options.updated_considered) {
    updated_share += (sensitivity.col(c) * out.considered_column_sigma(c)).cwiseAbs2();
  }
  for (int i = 0; i < n_rig; ++i) {
    if (named[i] || i >= static_cast<int>(options.nearly_unobservable_sigma.size())) continue;
    const double bound = options.nearly_unobservable_sigma[i];
    const double total = full(i, i) + considered_share(i, i) - updated_share(i);
    if (bound > 0 && !(std::sqrt(std::max(total, 0.0)) <= bound)) named[i] = true;
  }
  for (int i = 0; i < n_rig; ++i) {
    if (!named[i]) out.observable.push_back(i);
  }
  out.noise_covariance = Restrict(full, out.observable);
  out.covariance = Restrict(full + considered_share, out.observable);
  out.considered_sensitivity.resize(out.observable.size(), n_considered);
  for (size_t a = 0; a < out.observable.size(); ++a) {
    out.considered_sensitivity.row(a) = sensitivity.row(out.observable[a]);
  }
  for (int i = 0; i < n_rig; ++i) {
    if (named[i]) out.unobservable.push_back(i);
  }
  return out;
}

}  // namespace omni::calib
