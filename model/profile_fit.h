// A measured mirror profile (a profilometer or CMM scan, or the machinist's report) fitted to the
// profile terms of model/mirror_profile.h, so that a calibration can carry it as a prior of the
// scan's accuracy instead of the machining tolerance.
//
// The scan gives the surface's departure from the nominal conic along the body's +z axis at
// radii r (and azimuths theta, when it has several scan lines). Least squares over
//   sag(r, theta) = piston + sum_n sag_pn P_n(w) + sag_cos2 r^2 cos 2theta / r_max^2
//                 + sag_sin2 r^2 sin 2theta / r_max^2
// (w as in mirror_profile.h). The piston is the mirror's axial position, not a profile term: it
// is fitted and reported, never carried. One scan line (a single azimuth, or no azimuths) cannot
// tell astigmatism from the symmetric terms: the cos2 and sin2 terms are then left unmeasured.
// The terms' covariance is sigma^2 (A^T A)^-1 with the scan's stated accuracy sigma.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/mirror_profile.h"

namespace omni {

struct ProfileScanPoint {
  double r_mm = 0;
  double sag_mm = 0;     // departure from the conic along the body's +z (mm)
  double theta_rad = 0;  // the scan line's azimuth in the mirror's body frame
};

struct ProfileFit {
  std::array<double, kProfileTerms> coeffs{};  // sag_p1..sag_p4, sag_cos2, sag_sin2 (mm)
  // Which terms the scan determines (the astigmatism needs two azimuths at least 20 deg apart
  // modulo 90 deg); unmeasured terms are 0 with no covariance.
  std::array<bool, kProfileTerms> measured{};
  Eigen::Matrix<double, kProfileTerms, kProfileTerms> covariance =
      Eigen::Matrix<double, kProfileTerms, kProfileTerms>::Zero();
  double piston_mm = 0;          // the fitted constant (the mirror's axial offset): not carried
  int points = 0;                // scan points inside the profile's radii, used in the fit
  int skipped = 0;               // scan points outside them (not fitted)
  double residual_rms_mm = 0;    // of the scan about the fitted terms
  double residual_pv_mm = 0;     // peak to valley of those residuals (optical-shop form error)
  double scan_pv_mm = 0;         // peak to valley of the scan itself over the fitted radii
  // The terms' sigmas (sqrt of the covariance's diagonal; 0 where unmeasured).
  std::array<double, kProfileTerms> Sigma() const;
};

// Fits the terms to the scan points inside [shape.r_min, shape.r_max] with the scan's stated
// accuracy sigma_mm (> 0). The shape's ripple is not fitted (it is fixed data). Throws
// std::invalid_argument if fewer points than twice the fitted terms lie inside the radii.
ProfileFit FitProfileToScan(const std::vector<ProfileScanPoint>& scan, const ProfileShape& shape,
                            double sigma_mm);

}  // namespace omni
