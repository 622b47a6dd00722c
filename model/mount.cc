#include "model/mount.h"

#include <algorithm>
#include <cmath>

namespace omni {

bool SegmentHitsMount(const Mount& mount, const Pose<double>& cam_from_body,
                      const Eigen::Vector3d& a_in_cam, const Eigen::Vector3d& b_in_cam) {
  if (!mount.present) return false;
  const Pose<double> body_from_cam = cam_from_body.Inverse();
  const Eigen::Vector3d a = body_from_cam * a_in_cam;
  const Eigen::Vector3d d = body_from_cam * b_in_cam - a;
  for (size_t i = 0; i < mount.azimuths.size(); ++i) {
    const double azimuth = mount.azimuths[i], half = 0.5 * mount.WidthOf(i);
    // The post's frame: u radial, v tangential, z the body's axis; the post is the box
    // |u - radius| <= half, |v| <= half, z_min <= z <= z_max. Slab test on the segment t in [0, 1].
    const double c = std::cos(azimuth), s = std::sin(azimuth);
    const double au = c * a.x() + s * a.y() - mount.radius, av = -s * a.x() + c * a.y();
    const double du = c * d.x() + s * d.y(), dv = -s * d.x() + c * d.y();
    const double lo[3] = {-half, -half, mount.z_min}, hi[3] = {half, half, mount.z_max};
    const double o[3] = {au, av, a.z()}, dir[3] = {du, dv, d.z()};
    double t0 = 0, t1 = 1;
    bool miss = false;
    for (int k = 0; k < 3 && !miss; ++k) {
      if (std::abs(dir[k]) < 1e-15) {
        miss = o[k] < lo[k] || o[k] > hi[k];
        continue;
      }
      double ta = (lo[k] - o[k]) / dir[k], tb = (hi[k] - o[k]) / dir[k];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      miss = t0 > t1;
    }
    if (!miss) return true;
  }
  return false;
}

double Mount::MaxWidth() const {
  if (widths.empty()) return width;
  double widest = widths.front();
  for (double w : widths) widest = std::max(widest, w);
  return widest;
}

bool Mount::EqualWidths() const {
  for (double w : widths) {
    if (w != widths.front()) return false;
  }
  return true;
}

bool PostsOverlap(const Mount& mount) {
  const int n = static_cast<int>(mount.azimuths.size());
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const double gap = 2 * mount.radius * std::abs(std::sin(0.5 * (mount.azimuths[i] - mount.azimuths[j])));
      if (gap < 0.5 * (mount.WidthOf(i) + mount.WidthOf(j)) * std::sqrt(2.0)) return true;
    }
  }
  return false;
}

}  // namespace omni
