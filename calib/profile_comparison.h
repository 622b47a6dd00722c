// A measured mirror profile (a model file's profile_from: its fit was the calibration's prior on
// that mirror's terms) against the calibrated one, along the mirror's radius: what the report
// plots and the notes sum up.
#pragma once

#include <vector>

#include "calib/calibrate.h"

namespace omni::calib {

struct ProfileSample {
  double r_mm = 0;
  double measured_mm = 0;    // the scan's fit (the prior's mean)
  double calibrated_mm = 0;  // the calibrated terms
  double difference_mm = 0;  // calibrated - measured
  double sigma_mm = 0;       // of the difference
};

// Mirror `mirror` (1, 2)'s calibrated profile terms' covariance (rows and columns of terms not
// estimated 0) and its share from the considered parameters (their sensitivities and sigmas).
struct ProfileTermsCovariance {
  Eigen::Matrix<double, kProfileTerms, kProfileTerms> total, considered;
  bool estimated = false;  // some term was estimated
};
ProfileTermsCovariance ProfileCovarianceOf(const CalibrationResult& result, int mirror);

// Mirror `mirror` (1, 2)'s profile at azimuth theta_rad of its body frame, at `samples` radii
// evenly over the profile's radii, without the ripple (fixed data, the same in both). The sigma
// of the difference is sqrt(g^T D g), g the terms' gradient (ProfileTermGradient), with
// D = P - C_n + C_c: P the prior's covariance, C_n the calibrated terms' covariance from the
// noise and the prior (a posterior's departure from its prior mean has covariance P - C_n), C_c
// their considered share, which the prior does not hold (C_n = total - C_c); a held profile
// differs by 0 with sigma 0.
// Empty unless result.residuals.profile[mirror - 1].measured. `rig` is the calibrated rig
// (result.estimate.rig once Calibrate returns).
std::vector<ProfileSample> CompareWithMeasured(const RigParams& rig,
                                               const CalibrationResult& result, int mirror,
                                               double theta_rad, int samples);

}  // namespace omni::calib
