#include "model/model_compare.h"

#include <algorithm>
#include <cmath>

namespace omni {

std::vector<BandPoint> StereoBandPoints(const RigModel& model, double range_mm) {
  std::vector<BandPoint> points;
  for (int a = 0; a < 72; ++a) {
    const double azimuth = 2 * M_PI * a / 72;
    for (double z = -1.5 * range_mm; z <= 1.5 * range_mm; z += range_mm / 40) {
      const Eigen::Vector3d p(range_mm * std::cos(azimuth), range_mm * std::sin(azimuth), z);
      const auto p1 = model.Project(p, Mirror::kOne);
      const auto p2 = model.Project(p, Mirror::kTwo);
      if (p1 && p2) points.push_back({p, {*p1, *p2}});
    }
  }
  return points;
}

ProjectionDifference CompareProjections(const RigModel& reference, const RigModel& other,
                                        double range_mm) {
  ProjectionDifference diff;
  double sum2[2] = {0, 0};
  int n[2] = {0, 0};
  for (const BandPoint& p : StereoBandPoints(reference, range_mm)) {
    ++diff.points;
    for (int m = 0; m < 2; ++m) {
      const auto o = other.Project(p.point_in_cam, m == 0 ? Mirror::kOne : Mirror::kTwo);
      if (!o) {
        ++diff.lost;
        continue;
      }
      const double d = (*o - p.pixel[m]).norm();
      sum2[m] += d * d;
      ++n[m];
      diff.max_px[m] = std::max(diff.max_px[m], d);
    }
  }
  for (int m = 0; m < 2; ++m) diff.rms_px[m] = n[m] ? std::sqrt(sum2[m] / n[m]) : 0;
  return diff;
}

}  // namespace omni
