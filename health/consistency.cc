#include "health/consistency.h"

#include <algorithm>
#include <cmath>

#include "model/lip.h"
#include "model/rig_params.h"

namespace omni::health {
namespace {

constexpr double kMinRangeMm = 150;  // nearer than this a point on the ray is not a scene point

std::optional<Eigen::Vector2d> Ring2Pixel(const RigModel& model, const Ray& ray, double w) {
  return model.Project(ray.origin + ray.direction / w, Mirror::kTwo);
}

}  // namespace

std::optional<double> EpipolarGap(const RigModel& model, const Eigen::Vector2d& pixel1,
                                  const Eigen::Vector2d& pixel2, double* w_io) {
  const auto ray1 = model.Unproject(pixel1);
  if (!ray1 || ray1->mirror != Mirror::kOne) return std::nullopt;
  const Ray& r1 = ray1->ray;
  double w = w_io && *w_io > 0 ? *w_io : 0;
  if (w <= 0) {
    // Start at the common perpendicular of both rays (the midpoint's range along ray 1).
    const auto ray2 = model.Unproject(pixel2);
    if (!ray2 || ray2->mirror != Mirror::kTwo) return std::nullopt;
    const Eigen::Vector3d d1 = r1.direction, d2 = ray2->ray.direction;
    const Eigen::Vector3d w0 = r1.origin - ray2->ray.origin;
    const double b = d1.dot(d2), den = 1 - b * b;
    const double lambda = den > 1e-12 ? (b * d2.dot(w0) - d1.dot(w0)) / den : 2000;
    w = 1.0 / std::max(lambda, kMinRangeMm);
  }
  const double w_max = 1.0 / kMinRangeMm;
  Eigen::Vector2d p, tangent;
  for (int iteration = 0; iteration < 12; ++iteration) {
    const double h = 1e-3 * w;
    const auto a = Ring2Pixel(model, r1, w + h), b = Ring2Pixel(model, r1, w - h),
               c = Ring2Pixel(model, r1, w);
    if (!a || !b || !c) return std::nullopt;
    p = *c;
    tangent = (*a - *b) / (2 * h);  // d pixel / d w: towards decreasing range
    const double step = tangent.dot(pixel2 - p) / tangent.squaredNorm();
    w = std::clamp(w + step, 1e-6 * w_max, w_max);
    if (std::abs(step) * tangent.norm() < 1e-5) break;
  }
  const auto c = Ring2Pixel(model, r1, w);
  if (!c) return std::nullopt;
  if (w_io) *w_io = w;
  const Eigen::Vector2d t = tangent.normalized();
  const Eigen::Vector2d e = pixel2 - *c;
  return -e.x() * t.y() + e.y() * t.x();
}

std::optional<LipPointResidual> LipResidual(const RigModel& model, LipPath path,
                                            LipCircle circle, const Eigen::Vector2d& pixel) {
  LipPointResidual r;
  r.path = path;
  r.circle = circle;
  r.pixel = pixel;
  Eigen::Vector2d nearest;
  if (DistanceToLipEdgeImage(model, path, circle, pixel, &nearest, nullptr, &r.phi) > 1e8) {
    return std::nullopt;
  }
  // The edge's normal from its tangent (central differences in phi), turned to point away from
  // the principal point.
  const RigParams& rig = model.params();
  const Lip& lip = LipOf(rig, path);
  const double radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
  const RigBlocks<double> blocks = RigBlocksOf(rig);
  Eigen::Vector2d a, b;
  constexpr double kStep = 1e-4;
  if (!ProjectLipEdge(blocks, model.fixed(), path, radius, lip.z, r.phi + kStep, model.fixed().r_ref,
                      &a) ||
      !ProjectLipEdge(blocks, model.fixed(), path, radius, lip.z, r.phi - kStep, model.fixed().r_ref,
                      &b)) {
    return std::nullopt;
  }
  const Eigen::Vector2d t = (a - b).normalized();
  r.normal = Eigen::Vector2d(-t.y(), t.x());
  const Eigen::Vector2d outward = nearest - Eigen::Vector2d(rig.camera[kCx], rig.camera[kCy]);
  if (r.normal.dot(outward) < 0) r.normal = -r.normal;
  r.value = (pixel - nearest).dot(r.normal);
  return r;
}

std::optional<double> LipResidualUnder(const RigModel& model, const LipPointResidual& at) {
  const RigParams& rig = model.params();
  const Lip& lip = LipOf(rig, at.path);
  const double radius = at.circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
  Eigen::Vector2d q;
  if (!ProjectLipEdge(RigBlocksOf(rig), model.fixed(), at.path, radius, lip.z, at.phi,
                      model.fixed().r_ref, &q)) {
    return std::nullopt;
  }
  return (at.pixel - q).dot(at.normal);
}

}  // namespace omni::health
