#include "calib/profile_comparison.h"

#include <algorithm>
#include <cmath>

#include "model/profile_fit.h"

namespace omni::calib {

ProfileTermsCovariance ProfileCovarianceOf(const CalibrationResult& result, int mirror) {
  ProfileTermsCovariance c;
  c.total.setZero();
  c.considered.setZero();
  const std::vector<std::string>& term_names =
      BlockParameterNames(kRigBlocks[ProfileBlock(mirror == 1 ? Mirror::kOne : Mirror::kTwo)].name);
  const auto& names = result.estimate.names;
  const CalibrationUncertainty& u = result.uncertainty;
  int index[kProfileTerms];
  for (int k = 0; k < kProfileTerms; ++k) {
    const auto it = std::find(names.begin(), names.end(), term_names[k]);
    index[k] = it == names.end() ? -1 : static_cast<int>(it - names.begin());
    c.estimated |= index[k] >= 0;
  }
  const bool has_considered = u.considered_sensitivity.rows() == static_cast<int>(names.size()) &&
                              u.considered_sensitivity.cols() == u.considered_column_sigma.size();
  for (int j = 0; j < kProfileTerms; ++j) {
    for (int k = 0; k < kProfileTerms; ++k) {
      if (index[j] < 0 || index[k] < 0) continue;
      c.total(j, k) = u.covariance(index[j], index[k]);
      if (!has_considered) continue;
      c.considered(j, k) = (u.considered_sensitivity.row(index[j]).array() *
                            u.considered_column_sigma.transpose().array().square() *
                            u.considered_sensitivity.row(index[k]).array())
                               .sum();
    }
  }
  return c;
}

std::vector<ProfileSample> CompareWithMeasured(const RigParams& rig,
                                               const CalibrationResult& result, int mirror,
                                               double theta_rad, int samples) {
  const ProfileDecision& d = result.residuals.profile[mirror - 1];
  if (!d.measured || samples < 2) return {};
  using Matrix = Eigen::Matrix<double, kProfileTerms, kProfileTerms>;
  const ProfileShape& shape = mirror == 1 ? rig.profile1 : rig.profile2;
  const auto& coeffs = mirror == 1 ? rig.mirror1_profile : rig.mirror2_profile;
  const ProfileTermsCovariance c = ProfileCovarianceOf(result, mirror);
  // Held: the calibrated terms are the prior's mean, exactly.
  const Matrix difference_cov =
      c.estimated ? Matrix(d.prior_covariance - c.total + 2 * c.considered) : Matrix::Zero();
  std::vector<ProfileSample> out;
  for (int i = 0; i < samples; ++i) {
    ProfileSample s;
    s.r_mm = shape.r_min + (shape.r_max - shape.r_min) * i / (samples - 1);
    const std::array<double, kProfileTerms> g =
        ProfileTermGradient(shape, s.r_mm * std::cos(theta_rad), s.r_mm * std::sin(theta_rad));
    const Eigen::Map<const Eigen::Matrix<double, kProfileTerms, 1>> grad(g.data());
    for (int k = 0; k < kProfileTerms; ++k) {
      s.measured_mm += g[k] * d.prior_mean[k];
      s.calibrated_mm += g[k] * coeffs[k];
    }
    s.difference_mm = s.calibrated_mm - s.measured_mm;
    s.sigma_mm = std::sqrt(std::max(0.0, grad.dot(difference_cov * grad)));
    out.push_back(s);
  }
  return out;
}

}  // namespace omni::calib
