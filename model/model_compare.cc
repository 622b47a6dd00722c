#include "model/model_compare.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace omni {

std::vector<BandPoint> StereoBandPoints(const RigModel& model, double range_mm) {
  const bool single = model.params().Single();
  const Eigen::Vector2d none = Eigen::Vector2d::Constant(std::nan(""));
  std::vector<BandPoint> points;
  for (int a = 0; a < 72; ++a) {
    const double azimuth = 2 * M_PI * a / 72;
    for (double z = -1.5 * range_mm; z <= 1.5 * range_mm; z += range_mm / 40) {
      const Eigen::Vector3d p(range_mm * std::cos(azimuth), range_mm * std::sin(azimuth), z);
      const auto p1 = model.Project(p, Mirror::kOne);
      if (single) {
        if (p1) points.push_back({p, {*p1, none}});
        continue;
      }
      const auto p2 = model.Project(p, Mirror::kTwo);
      if (p1 && p2) points.push_back({p, {*p1, *p2}});
    }
  }
  return points;
}

namespace {

Eigen::Matrix3d RotationOf(const Eigen::Vector3d& rotation) {
  const double angle = rotation.norm();
  if (angle == 0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix();
}

// `other` projects other_from_reference * p where the reference saw p.
ProjectionDifference Difference(const std::vector<BandPoint>& points, const RigModel& other,
                                const Eigen::Isometry3d& other_from_reference) {
  ProjectionDifference diff;
  double sum2[2] = {0, 0};
  int n[2] = {0, 0};
  for (const BandPoint& p : points) {
    ++diff.points;
    for (int m = 0; m < other.params().Paths(); ++m) {
      const auto o =
          other.Project(other_from_reference * p.point_in_cam, m == 0 ? Mirror::kOne : Mirror::kTwo);
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

// Stacked pixel differences (both rings; zero where `other` does not project).
Eigen::VectorXd Residuals(const std::vector<BandPoint>& points, const RigModel& other,
                          const Eigen::Vector3d& rotation) {
  const Eigen::Matrix3d r = RotationOf(rotation);
  Eigen::VectorXd res = Eigen::VectorXd::Zero(4 * points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    for (int m = 0; m < other.params().Paths(); ++m) {
      const auto o = other.Project(r * points[i].point_in_cam, m == 0 ? Mirror::kOne : Mirror::kTwo);
      if (o) res.segment<2>(4 * i + 2 * m) = *o - points[i].pixel[m];
    }
  }
  return res;
}

}  // namespace

ProjectionDifference CompareProjections(const RigModel& reference, const RigModel& other,
                                        double range_mm) {
  return Difference(StereoBandPoints(reference, range_mm), other, Eigen::Isometry3d::Identity());
}

ProjectionDifference CompareProjectionsUpToRotation(const RigModel& reference,
                                                    const RigModel& other, double range_mm,
                                                    Eigen::Vector3d* rotation_rad) {
  const std::vector<BandPoint> points = StereoBandPoints(reference, range_mm);
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();
  // Gauss-Newton with central-difference Jacobians; the rotations that matter are < 1 deg and
  // the problem is nearly linear there, so a few steps converge.
  constexpr double kStep = 1e-6;
  for (int iteration = 0; iteration < 5; ++iteration) {
    const Eigen::VectorXd r0 = Residuals(points, other, rotation);
    Eigen::MatrixXd jacobian(r0.size(), 3);
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d plus = rotation, minus = rotation;
      plus(k) += kStep;
      minus(k) -= kStep;
      jacobian.col(k) =
          (Residuals(points, other, plus) - Residuals(points, other, minus)) / (2 * kStep);
    }
    const Eigen::Vector3d step = jacobian.colPivHouseholderQr().solve(-r0);
    rotation += step;
    if (step.norm() < 1e-12) break;
  }
  if (rotation_rad) *rotation_rad = rotation;
  return Difference(points, other, Eigen::Isometry3d(RotationOf(rotation)));
}

namespace {

Eigen::Isometry3d CamFromMirror1(const RigModel& model) {
  const Pose<double>& pose = model.path1().cam_from_mirror;
  Eigen::Isometry3d cam_from_mirror1 = Eigen::Isometry3d::Identity();
  cam_from_mirror1.linear() = pose.rotation;
  cam_from_mirror1.translation() = pose.translation;
  return cam_from_mirror1;
}

}  // namespace

ProjectionDifference CompareProjectionsInMirror1(const RigModel& reference, const RigModel& other,
                                                 double range_mm) {
  // A single mirror's body frame puts its vertex at vertex_z, a convention each model may set
  // differently (init's start and the true rig): the points are held against the vertex.
  Eigen::Isometry3d other_m1_from_reference_m1 = Eigen::Isometry3d::Identity();
  other_m1_from_reference_m1.translation().z() =
      other.params().vertex_z - reference.params().vertex_z;
  const Eigen::Isometry3d other_from_reference = CamFromMirror1(other) *
                                                 other_m1_from_reference_m1 *
                                                 CamFromMirror1(reference).inverse();
  return Difference(StereoBandPoints(reference, range_mm), other, other_from_reference);
}

}  // namespace omni
