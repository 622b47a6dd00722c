// A measured mirror profile (a profilometer or CMM scan, or the machinist's report) fitted to the
// profile terms of model/mirror_profile.h, so that a calibration can carry it as a prior of the
// scan's accuracy instead of the machining tolerance.
//
// The scan gives the surface's departure from the nominal conic along the body's +z axis at
// radii r (and azimuths theta, when it has several scan lines). Least squares over
//   sag(r, theta) = piston + sum_n sag_pn P_n(w) + sag_cos2 r^2 cos 2theta / r_max^2
//                 + sag_sin2 r^2 sin 2theta / r_max^2
// (w as in mirror_profile.h). The piston is the mirror's axial position, not a profile term: it
// is fitted and reported, never carried. Fewer than three azimuths (distinct in 2 theta) cannot
// tell astigmatism from the symmetric terms' r^2: the cos2 and sin2 terms are then left
// unmeasured.
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
  // Which terms the scan determines (the astigmatism needs three azimuths distinct in 2 theta);
  // unmeasured terms are 0 with no covariance.
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

// d sag / d coefficient of each term at (x, y) in the mirror's body frame, the ripple left out.
// The sag is linear in the coefficients: a profile of covariance C has sigma(sag)^2 = g^T C g.
std::array<double, kProfileTerms> ProfileTermGradient(const ProfileShape& shape, double x,
                                                      double y);

// A mirror's profile as measured (a model file's `profile_from:`): the scan, the accuracy it was
// stated with and its fit, whose terms are the mirror's profile coefficients. A calibration
// carries the fit as the prior on that mirror's terms instead of the machining tolerance.
struct MeasuredProfile {
  std::string scan_file;   // as the model file names it
  double accuracy_mm = 0;  // the stated accuracy of each scan point
  std::vector<ProfileScanPoint> scan;
  ProfileFit fit;
};

// The prior a measured profile gives its terms: the fit's covariance over the measured terms and
// tolerance_mm^2 (the machining tolerance) on the unmeasured ones (a single scan line's
// astigmatism), uncorrelated with them.
Eigen::Matrix<double, kProfileTerms, kProfileTerms> MeasuredPriorCovariance(const ProfileFit& fit,
                                                                           double tolerance_mm);

}  // namespace omni
