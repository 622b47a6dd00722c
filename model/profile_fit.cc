#include "model/profile_fit.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace omni {
namespace {

// Two azimuths tell astigmatism from the symmetric terms unless cos 2theta and sin 2theta agree
// for both (theta equal modulo 180 deg): they must differ by at least this in 2 theta.
constexpr double kMinAzimuthSpreadRad = 20.0 * M_PI / 180.0;

bool ScanHasAzimuths(const std::vector<ProfileScanPoint>& scan) {
  for (const ProfileScanPoint& p : scan) {
    const double d = std::remainder(2 * (p.theta_rad - scan.front().theta_rad), 2 * M_PI);
    if (std::abs(d) >= kMinAzimuthSpreadRad) return true;
  }
  return false;
}

}  // namespace

std::array<double, kProfileTerms> ProfileFit::Sigma() const {
  std::array<double, kProfileTerms> sigma{};
  for (int i = 0; i < kProfileTerms; ++i) sigma[i] = std::sqrt(std::max(0.0, covariance(i, i)));
  return sigma;
}

ProfileFit FitProfileToScan(const std::vector<ProfileScanPoint>& scan, const ProfileShape& shape,
                            double sigma_mm) {
  if (!(sigma_mm > 0)) throw std::invalid_argument("the scan's accuracy must be > 0 mm");
  ProfileShape terms_only = shape;  // the ripple is fixed data, not a fitted term
  terms_only.ripple_amplitude = 0;
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
    a(i, 0) = 1;
    for (size_t j = 0; j < terms.size(); ++j) {
      std::array<double, kProfileTerms> unit{};
      unit[terms[j]] = 1;
      a(i, 1 + j) = ProfileSag(unit.data(), terms_only, x, y, /*second=*/false).z;
    }
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
