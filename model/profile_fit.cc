#include "model/profile_fit.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace omni {
namespace {

// The astigmatism's r^2 cos 2theta and r^2 sin 2theta are told from the symmetric terms' r^2
// only where (1, cos 2theta, sin 2theta) over the scan's points spans three dimensions: at least
// three azimuths distinct in 2 theta (two lines leave one combination of the three r^2
// coefficients open). The smallest eigenvalue of their mean outer product must reach this
// (three lines 0, 45, 90 deg: 0.20; 0, 60, 120 deg: 0.5).
constexpr double kMinAzimuthSpread = 0.05;

bool ScanHasAzimuths(const std::vector<ProfileScanPoint>& scan) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (const ProfileScanPoint& p : scan) {
    const Eigen::Vector3d v(1, std::cos(2 * p.theta_rad), std::sin(2 * p.theta_rad));
    m += v * v.transpose();
  }
  m /= static_cast<double>(scan.size());
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m).eigenvalues()(0) >= kMinAzimuthSpread;
}

}  // namespace

std::array<double, kProfileTerms> ProfileFit::Sigma() const {
  std::array<double, kProfileTerms> sigma{};
  for (int i = 0; i < kProfileTerms; ++i) sigma[i] = std::sqrt(std::max(0.0, covariance(i, i)));
  return sigma;
}

std::array<double, kProfileTerms> ProfileTermGradient(const ProfileShape& shape, double x,
                                                      double y) {
  ProfileShape terms_only = shape;  // the ripple is fixed data, not a term
  terms_only.ripple_amplitude = 0;
  std::array<double, kProfileTerms> g{};
  for (int k = 0; k < kProfileTerms; ++k) {
    std::array<double, kProfileTerms> unit{};
    unit[k] = 1;
    g[k] = ProfileSag(unit.data(), terms_only, x, y, /*second=*/false).z;
  }
  return g;
}

Eigen::Matrix<double, kProfileTerms, kProfileTerms> MeasuredPriorCovariance(const ProfileFit& fit,
                                                                           double tolerance_mm) {
  Eigen::Matrix<double, kProfileTerms, kProfileTerms> c = fit.covariance;
  for (int k = 0; k < kProfileTerms; ++k) {
    if (fit.measured[k]) continue;
    c.row(k).setZero();
    c.col(k).setZero();
    c(k, k) = tolerance_mm * tolerance_mm;
  }
  return c;
}

ProfileFit FitProfileToScan(const std::vector<ProfileScanPoint>& scan, const ProfileShape& shape,
                            double sigma_mm) {
  if (!(sigma_mm > 0)) throw std::invalid_argument("the scan's accuracy must be > 0 mm");
  std::vector<ProfileScanPoint> inside;
  ProfileFit fit;
  for (const ProfileScanPoint& p : scan) {
    if (p.r_mm >= shape.r_min && p.r_mm <= shape.r_max) {
      inside.push_back(p);
    } else {
      ++fit.skipped;
    }
  }
  const bool astigmatism = !inside.empty() && ScanHasAzimuths(inside);
  // Columns: the piston, then the measured terms.
  std::vector<int> terms = {0, 1, 2, 3};
  if (astigmatism) terms.insert(terms.end(), {4, 5});
  const int n_cols = 1 + static_cast<int>(terms.size());
  if (static_cast<int>(inside.size()) < 2 * n_cols) {
    throw std::invalid_argument("the scan has " + std::to_string(inside.size()) +
                                " points inside the profile's radii; at least " +
                                std::to_string(2 * n_cols) + " are needed");
  }
  Eigen::MatrixXd a(inside.size(), n_cols);
  Eigen::VectorXd b(inside.size());
  for (size_t i = 0; i < inside.size(); ++i) {
    const double x = inside[i].r_mm * std::cos(inside[i].theta_rad);
    const double y = inside[i].r_mm * std::sin(inside[i].theta_rad);
    const std::array<double, kProfileTerms> g = ProfileTermGradient(shape, x, y);
    a(i, 0) = 1;
    for (size_t j = 0; j < terms.size(); ++j) a(i, 1 + j) = g[terms[j]];
    b(i) = inside[i].sag_mm;
  }
  const Eigen::MatrixXd normal = a.transpose() * a;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
  const Eigen::VectorXd solution = ldlt.solve(a.transpose() * b);
  const Eigen::MatrixXd inverse =
      ldlt.solve(Eigen::MatrixXd::Identity(n_cols, n_cols)) * (sigma_mm * sigma_mm);
  fit.piston_mm = solution(0);
  for (size_t j = 0; j < terms.size(); ++j) {
    fit.coeffs[terms[j]] = solution(1 + j);
    fit.measured[terms[j]] = true;
    for (size_t k = 0; k < terms.size(); ++k) {
      fit.covariance(terms[j], terms[k]) = inverse(1 + j, 1 + k);
    }
  }
  const Eigen::VectorXd residual = b - a * solution;
  fit.points = static_cast<int>(inside.size());
  fit.residual_rms_mm = std::sqrt(residual.squaredNorm() / residual.size());
  fit.residual_pv_mm = residual.maxCoeff() - residual.minCoeff();
  fit.scan_pv_mm = b.maxCoeff() - b.minCoeff();
  return fit;
}

}  // namespace omni
