#include "model/model_compare.h"

#include <algorithm>
#include <cmath>

namespace omni {

ProjectionDifference CompareProjections(const RigModel& reference, const RigModel& other,
                                        double range_mm) {
  ProjectionDifference diff;
  double sum2[2] = {0, 0};
  int n[2] = {0, 0};
  for (int a = 0; a < 72; ++a) {
    const double azimuth = 2 * M_PI * a / 72;
    for (double z = -1.5 * range_mm; z <= 1.5 * range_mm; z += range_mm / 40) {
      const Eigen::Vector3d p(range_mm * std::cos(azimuth), range_mm * std::sin(azimuth), z);
      const auto r1 = reference.Project(p, Mirror::kOne);
      const auto r2 = reference.Project(p, Mirror::kTwo);
      if (!r1 || !r2) continue;
      ++diff.points;
      for (int m = 0; m < 2; ++m) {
        const auto o = other.Project(p, m == 0 ? Mirror::kOne : Mirror::kTwo);
        if (!o) {
          ++diff.lost;
          continue;
        }
        const double d = (*o - (m == 0 ? *r1 : *r2)).norm();
        sum2[m] += d * d;
        ++n[m];
        diff.max_px[m] = std::max(diff.max_px[m], d);
      }
    }
  }
  for (int m = 0; m < 2; ++m) diff.rms_px[m] = n[m] ? std::sqrt(sum2[m] / n[m]) : 0;
  return diff;
}

}  // namespace omni
