#include "model/mirror_profile.h"

#include <algorithm>
#include <cmath>

namespace omni {

ProfileExtent MeasureProfile(const std::array<double, kProfileTerms>& coeffs,
                             const ProfileShape& shape) {
  ProfileExtent extent;
  const double step = 0.05;
  const int n = std::max(2, static_cast<int>(std::ceil((shape.r_max - shape.r_min) / step)) + 1);
  for (int i = 0; i < n; ++i) {
    const double r = shape.r_min + (shape.r_max - shape.r_min) * i / (n - 1);
    for (int deg = 0; deg < 360; ++deg) {
      const double a = deg * M_PI / 180;
      const Sag<double> s =
          ProfileSag(coeffs.data(), shape, r * std::cos(a), r * std::sin(a), /*second=*/false);
      extent.max_sag_mm = std::max(extent.max_sag_mm, std::abs(s.z));
      extent.max_slope = std::max(extent.max_slope, std::hypot(s.zx, s.zy));
    }
  }
  return extent;
}

}  // namespace omni
