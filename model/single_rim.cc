#include "model/single_rim.h"

#include <algorithm>
#include <cmath>

#include "model/conic.h"
#include "model/lip.h"
#include "model/rig_frames.h"

namespace omni {

bool RimEdgeIsTheRim(const RigModel& model, double* elevation_deg) {
  const RigParams& rig = model.params();
  if (!rig.Single()) return false;
  const RigBlocks<double> blocks = RigBlocksOf(rig);
  const Eigen::Vector3d axis_in_cam =
      PoseFromBlock(rig.mirror1_pose.data()).Rotate(Eigen::Vector3d::UnitZ());
  const Eigen::Vector2d principal(rig.camera[kCx], rig.camera[kCy]);
  // One pixel inside the rim's image at 16 azimuths: the reflected ray's elevation from the
  // rim's plane (the axis points from the vertex to the rim: away from the camera).
  double steepest = -90;
  int traced = 0;
  for (int k = 0; k < 16; ++k) {
    Eigen::Vector2d rim_px;
    if (!ProjectLipPoint(blocks, model.fixed(), LipPath::kDirect, rig.r_sys, SingleRimZ(rig),
                         2 * M_PI * (k + 0.5) / 16, &rim_px)) {
      continue;
    }
    const Eigen::Vector2d inside = rim_px - (rim_px - principal).normalized();
    const auto ray = model.Unproject(inside);
    if (!ray) continue;
    const double sine = std::clamp(ray->ray.direction.normalized().dot(axis_in_cam), -1.0, 1.0);
    steepest = std::max(steepest, std::asin(sine) * 180 / M_PI);
    ++traced;
  }
  if (elevation_deg) *elevation_deg = steepest;
  // A fraction of a degree past the plane: a thin holder at the rim is seen edge on.
  return traced >= 8 && steepest <= 0.5;
}

RigParams WithRimCircleAt(const RigParams& rig, double radius_mm) {
  RigParams out = rig;
  const Conic<double> conic{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
  out.lip1.r_inner = out.lip1.r_outer = radius_mm;
  out.lip1.z = rig.vertex_z + conic.Sag(radius_mm * radius_mm);
  return out;
}

RigParams WithMirrorReaching(const RigParams& rig, double radius_mm) {
  if (!(radius_mm > rig.r_sys)) return rig;
  RigParams out = WithRimCircleAt(rig, radius_mm);
  out.r_sys = radius_mm;
  return out;
}

std::vector<double> RadialOffsetsFromCircle(const RigModel& model, double r,
                                           const std::vector<Eigen::Vector2d>& points) {
  const RigParams circle_rig = WithRimCircleAt(model.params(), r);
  const RigBlocks<double> blocks = RigBlocksOf(circle_rig);
  constexpr int kAzimuths = 720;
  std::vector<Eigen::Vector2d> curve;
  for (int k = 0; k < kAzimuths; ++k) {
    Eigen::Vector2d px;
    if (!ProjectLipPoint(blocks, model.fixed(), LipPath::kDirect, r, circle_rig.lip1.z,
                         2 * M_PI * (k + 0.5) / kAzimuths, &px)) {
      return {};
    }
    curve.push_back(px);
  }
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& c : curve) centre += c / kAzimuths;
  // The curve's radius by its angle about the centre, in 720 sectors (the curve is near a circle).
  std::vector<double> radius_at(kAzimuths, std::nan(""));
  for (const Eigen::Vector2d& c : curve) {
    const double angle = std::atan2(c.y() - centre.y(), c.x() - centre.x());
    const int sector = static_cast<int>(std::floor((angle + M_PI) / (2 * M_PI) * kAzimuths)) % kAzimuths;
    radius_at[sector] = (c - centre).norm();
  }
  std::vector<double> offsets;
  for (const Eigen::Vector2d& p : points) {
    const double angle = std::atan2(p.y() - centre.y(), p.x() - centre.x());
    int sector = static_cast<int>(std::floor((angle + M_PI) / (2 * M_PI) * kAzimuths)) % kAzimuths;
    for (int step = 0; step < 8 && std::isnan(radius_at[sector]); ++step) {
      sector = (sector + 1) % kAzimuths;
    }
    if (std::isnan(radius_at[sector])) continue;
    offsets.push_back((p - centre).norm() - radius_at[sector]);
  }
  return offsets;
}

namespace {

// The median of RadialOffsetsFromCircle; NaN where there is none.
double MedianOffsetFromCircle(const RigModel& model, double r,
                              const std::vector<Eigen::Vector2d>& points) {
  std::vector<double> offsets = RadialOffsetsFromCircle(model, r, points);
  if (offsets.empty()) return std::nan("");
  std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
  return offsets[offsets.size() / 2];
}

}  // namespace

double RimCircleRadiusOf(const RigModel& model, const std::vector<Eigen::Vector2d>& edge_points) {
  if (edge_points.size() < 20) return 0;
  const double r_sys = model.params().r_sys;
  double lo = 0.2 * r_sys, hi = 2.0 * r_sys;
  double f_lo = MedianOffsetFromCircle(model, lo, edge_points);
  double f_hi = MedianOffsetFromCircle(model, hi, edge_points);
  // A conic that ends before 2 r_sys (an ellipsoid, a sphere): the largest radius it projects.
  for (int k = 0; k < 20 && std::isnan(f_hi) && hi > lo; ++k) {
    hi = lo + 0.8 * (hi - lo);
    f_hi = MedianOffsetFromCircle(model, hi, edge_points);
  }
  if (std::isnan(f_lo) || std::isnan(f_hi) || f_lo * f_hi > 0) return 0;
  // The image grows with the radius: the offset falls from + to -.
  for (int k = 0; k < 60 && hi - lo > 1e-5; ++k) {
    const double mid = 0.5 * (lo + hi);
    const double f_mid = MedianOffsetFromCircle(model, mid, edge_points);
    if (std::isnan(f_mid)) return 0;
    if ((f_mid > 0) == (f_lo > 0)) lo = mid, f_lo = f_mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace omni
