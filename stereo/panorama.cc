#include "stereo/panorama.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "model/model_derived.h"

namespace omni::stereo {

double PanoramaGeometry::Azimuth(double u) const { return 2 * M_PI - u * l_px; }

double PanoramaGeometry::Elevation(double v) const { return std::atan(z_max - v * l_px); }

double PanoramaGeometry::RowOfElevation(double theta) const {
  return (z_max - std::tan(theta)) / l_px;
}

Eigen::Vector3d PanoramaGeometry::PointOnCylinder(Mirror mirror, double u, double v) const {
  const double psi = Azimuth(u);
  const Eigen::Vector3d in_cylinder(std::cos(psi), std::sin(psi), z_max - v * l_px);
  return viewpoint_in_cam[MirrorIndex(mirror) - 1] + radius_mm * (cam_from_cylinder * in_cylinder);
}

Eigen::Vector2d PanoramaGeometry::PanoramaPixel(Mirror mirror,
                                                const Eigen::Vector3d& point_in_cam) const {
  const Eigen::Vector3d p =
      cam_from_cylinder.transpose() * (point_in_cam - viewpoint_in_cam[MirrorIndex(mirror) - 1]);
  const double rho = p.head<2>().norm();
  double psi = std::atan2(p.y(), p.x());
  if (psi <= 0) psi += 2 * M_PI;
  return Eigen::Vector2d((2 * M_PI - psi) / l_px, (z_max - p.z() / rho) / l_px);
}

namespace {

// The cylinder's frame: its axis, azimuth 0 at C's +x projected normal to it.
void SetCylinderAxis(const Eigen::Vector3d& axis, PanoramaGeometry* g) {
  const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - axis.x() * axis).normalized();
  g->cam_from_cylinder.col(0) = x;
  g->cam_from_cylinder.col(1) = axis.cross(x);
  g->cam_from_cylinder.col(2) = axis;
}

}  // namespace

std::string PanoramaOptions::Check() const {
  if (width < 8) return "panorama width: expected at least 8";
  if (!(cylinder_radius_mm > 0)) return "panorama cylinder radius: expected > 0 mm";
  return "";
}

PanoramaGeometry MakePanoramaGeometry(const RigModel& model, const PanoramaOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) {
    throw std::invalid_argument(error);
  }
  const RigParams& rig = model.params();
  PanoramaGeometry g;
  double theta_min = options.theta_min, theta_max = options.theta_max;
  if (std::isnan(theta_min) || std::isnan(theta_max)) {
    // [cylinder_height] from the system's elevation limits [vFOV_system].
    const FieldOfView fov = RigFieldOfView(rig);
    if (std::isnan(theta_min)) theta_min = fov.theta_sys_min;
    if (std::isnan(theta_max)) theta_max = fov.theta_sys_max;
  }
  if (!(theta_min < theta_max) || !(theta_max < M_PI / 2) || !(theta_min > -M_PI / 2)) {
    throw std::invalid_argument("panorama elevation limits: expected -90 < min < max < 90 deg");
  }
  g.width = options.width;
  g.l_px = 2 * M_PI / options.width;  // [panorama_pixel_size] with w_cyl = 2 pi
  g.z_max = std::tan(theta_max);
  g.z_min = std::tan(theta_min);
  g.height = std::max(1, static_cast<int>(std::lround((g.z_max - g.z_min) / g.l_px)));
  g.radius_mm = options.cylinder_radius_mm;
  g.rings = rig.Paths();
  if (rig.Single()) {
    // One ring: its mirror's near focus, the cylinder coaxial with the mirror.
    const ModelDerived derived = ComputeModelDerived(rig);
    g.viewpoint_in_cam[0] = derived.focus1_in_cam;
    g.viewpoint_in_cam[1] = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    SetCylinderAxis(derived.axis1_in_cam.normalized(), &g);
    return g;
  }
  g.viewpoint_in_cam[0] = Focus1InCam(rig.mirror1_pose.data(), rig.mirror1_shape.data());
  g.viewpoint_in_cam[1] = Focus2InCam(rig.mirror2_pose.data(), rig.mirror2_shape.data(), rig.d);
  // The common axis: the baseline direction (from F2 up to F1).
  SetCylinderAxis((g.viewpoint_in_cam[0] - g.viewpoint_in_cam[1]).normalized(), &g);
  return g;
}

PanoramaLuts BuildPanoramaLuts(const RigModel& model, const PanoramaOptions& options) {
  PanoramaLuts luts;
  luts.geometry = MakePanoramaGeometry(model, options);
  const PanoramaGeometry& g = luts.geometry;
  for (int i = 0; i < g.rings; ++i) {
    const Mirror mirror = i == 0 ? Mirror::kOne : Mirror::kTwo;
    luts.map_x[i].create(g.height, g.width, CV_32FC1);
    luts.map_y[i].create(g.height, g.width, CV_32FC1);
    cv::parallel_for_(cv::Range(0, g.height), [&](const cv::Range& rows) {
      for (int v = rows.start; v < rows.end; ++v) {
        float* mx = luts.map_x[i].ptr<float>(v);
        float* my = luts.map_y[i].ptr<float>(v);
        for (int u = 0; u < g.width; ++u) {
          const auto px = model.Project(g.PointOnCylinder(mirror, u, v), mirror);
          mx[u] = px ? static_cast<float>(px->x()) : -1.f;
          my[u] = px ? static_cast<float>(px->y()) : -1.f;
        }
      }
    });
    cv::convertMaps(luts.map_x[i], luts.map_y[i], luts.fixed_xy[i], luts.fixed_frac[i], CV_16SC2);
    int first = g.height, last = -1;
    for (int v = 0; v < g.height; ++v) {
      double max_x = 0;
      cv::minMaxLoc(luts.map_x[i].row(v), nullptr, &max_x);
      if (max_x >= 0) first = std::min(first, v), last = v;
    }
    luts.valid_rows[i] = last < 0 ? cv::Range(0, 0) : cv::Range(first, last + 1);
  }
  return luts;
}

void Unwarp(const cv::Mat& image, const PanoramaLuts& luts, Mirror mirror, cv::Mat* panorama) {
  Unwarp(image, luts, mirror, cv::Range::all(), panorama);
}

void Unwarp(const cv::Mat& image, const PanoramaLuts& luts, Mirror mirror, cv::Range wanted,
            cv::Mat* panorama) {
  const int i = MirrorIndex(mirror) - 1;
  if (i >= luts.geometry.rings) {
    throw std::invalid_argument("panorama of mirror 2: the rig has one ring");
  }
  cv::Range rows = luts.valid_rows[i];
  if (wanted != cv::Range::all()) {
    rows = cv::Range(std::max(rows.start, wanted.start), std::min(rows.end, wanted.end));
    if (rows.start >= rows.end) rows = cv::Range(0, 0);
  }
  panorama->create(luts.fixed_xy[i].rows, luts.fixed_xy[i].cols, image.type());
  panorama->rowRange(0, rows.start).setTo(cv::Scalar::all(0));
  panorama->rowRange(rows.end, panorama->rows).setTo(cv::Scalar::all(0));
  if (rows.empty()) return;
  cv::Mat band = panorama->rowRange(rows);
  cv::remap(image, band, luts.fixed_xy[i].rowRange(rows), luts.fixed_frac[i].rowRange(rows),
            cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
}

}  // namespace omni::stereo
