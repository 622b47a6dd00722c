// The 99% quantile of chi^2, for the calibration's decisions at the 1% level (a profile's radial
// pattern, calib/profiles.cc; a single mirror's non-central part, calib/central_decision.cc).
#pragma once

#include <cmath>

namespace omni::calib {

// The 99% quantile of chi^2 with k degrees of freedom (Wilson-Hilferty; within 1% for k >= 2,
// 6.60 against 6.63 for k = 1).
inline double Chi2Quantile99(int k) {
  const double z = 2.3263;  // the standard normal's 99% quantile
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1 - a + z * std::sqrt(a), 3);
}

}  // namespace omni::calib
