#include "model/rig_model.h"

#include <cmath>

namespace omni {

RigFixed FixedOf(const RigParams& rig) {
  RigFixed fixed;
  fixed.rig = rig.rig;
  fixed.lens = rig.lens;
  fixed.vertex_z = rig.vertex_z;
  fixed.d = rig.d;
  fixed.r_sys = rig.r_sys;
  fixed.r_ref = rig.r_ref;
  fixed.r_cam = rig.r_cam;
  fixed.profile1 = rig.profile1;
  fixed.profile2 = rig.profile2;
  fixed.mount = rig.mount;
  if (rig.mount.present) {
    fixed.cam_from_mount = PoseFromBlock(rig.mount.body == Mirror::kOne ? rig.mirror1_pose.data()
                                                                         : rig.mirror2_pose.data());
  }
  fixed.solver.max_radius = 5 * rig.r_sys;
  return fixed;
}

RigModel::RigModel(const RigParams& params)
    : params_(params),
      fixed_(FixedOf(params)),
      path1_(Mirror1Path<double>::FromBlocks(RigBlocksOf(params), fixed_)),
      path2_(Mirror2Path<double>::FromBlocks(RigBlocksOf(params), fixed_)) {}

std::optional<Eigen::Vector2d> RigModel::Project(const Eigen::Vector3d& point_in_cam,
                                                 Mirror mirror, ProjectionInfo* info) const {
  Eigen::Vector2d pixel;
  if (mirror == Mirror::kTwo && fixed_.rig == RigKind::kSingle) return std::nullopt;
  const bool ok = mirror == Mirror::kOne ? path1_.Project(fixed_, point_in_cam, &pixel, info)
                                         : path2_.Project(fixed_, point_in_cam, &pixel, info);
  if (!ok || !pixel.allFinite()) return std::nullopt;
  return pixel;
}

bool RigModel::BlockedByMount(const std::vector<Eigen::Vector3d>& camera_path,
                              const Ray& world_ray) const {
  if (!fixed_.mount.present) return false;
  for (size_t i = 0; i + 1 < camera_path.size(); ++i) {
    if (SegmentHitsMount(fixed_.mount, fixed_.cam_from_mount, camera_path[i], camera_path[i + 1])) {
      return true;
    }
  }
  // The reflected ray as far as the posts could stand in its way.
  const double reach = 4 * (fixed_.mount.radius + fixed_.mount.MaxWidth() + std::abs(fixed_.mount.z_max) +
                            std::abs(fixed_.mount.z_min));
  return SegmentHitsMount(fixed_.mount, fixed_.cam_from_mount, world_ray.origin,
                          world_ray.origin + reach * world_ray.direction);
}

std::optional<MirrorRay> RigModel::Unproject(const Eigen::Vector2d& pixel) const {
  bool blocked = false;
  auto ray = Trace(pixel, &blocked, nullptr);
  if (blocked) return std::nullopt;
  return ray;
}

bool RigModel::PixelSeesMount(const Eigen::Vector2d& pixel) const {
  if (!fixed_.mount.present) return false;
  bool blocked = false;
  Eigen::Vector3d dir_in_cam = Eigen::Vector3d::Zero();
  if (Trace(pixel, &blocked, &dir_in_cam)) return blocked;
  // No mirror: the camera's own ray, as far as the posts stand.
  if (!(dir_in_cam.squaredNorm() > 0)) return false;
  return BlockedByMount({}, Ray{Eigen::Vector3d::Zero(), dir_in_cam});
}

std::optional<MirrorRay> RigModel::Trace(const Eigen::Vector2d& pixel, bool* blocked,
                                         Eigen::Vector3d* camera_dir) const {
  *blocked = false;
  if (!pixel.allFinite()) return std::nullopt;
  Eigen::Vector2d xy;
  if (!Undistort(path1_.dist, path1_.cam.NormalizedFromPixel(pixel), &xy)) return std::nullopt;
  if (fixed_.rig == RigKind::kSingle) return TraceSingle(xy, blocked, camera_dir);
  const Eigen::Vector3d dir_in_cam = Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
  if (camera_dir) *camera_dir = dir_in_cam;

  // Does the camera ray cross the reflex plane inside the disc?
  const Plane<double>& reflex = path2_.reflex_in_cam;
  const double approach = dir_in_cam.dot(reflex.normal);  // < 0 towards the plane
  const double camera_side = -reflex.point.dot(reflex.normal);
  if (camera_side > 0 && approach < 0) {
    const Eigen::Vector3d crossing = (camera_side / -approach) * dir_in_cam;
    if ((crossing - reflex.point).squaredNorm() <= fixed_.r_ref * fixed_.r_ref) {
      // Reflected by the disc towards mirror 2.
      const Eigen::Vector3d down_in_cam = Reflect(dir_in_cam, reflex.normal);
      const Eigen::Vector3d origin = path2_.mirror_from_cam * crossing;
      const Eigen::Vector3d dir = path2_.mirror_from_cam.Rotate(down_in_cam);
      double t = 0;
      if (!path2_.sheet.IntersectRay(origin, dir, &t)) return std::nullopt;
      const Eigen::Vector3d s = origin + t * dir;
      const double r2 = s.head<2>().squaredNorm();
      if (r2 < fixed_.r_cam * fixed_.r_cam || r2 > fixed_.r_sys * fixed_.r_sys) return std::nullopt;
      const Eigen::Vector3d normal = path2_.sheet.Normal(s);
      if (!(dir.dot(normal) > 0)) return std::nullopt;  // hit from the back
      MirrorRay out{Mirror::kTwo, Ray{}};
      out.ray.origin = path2_.cam_from_mirror * s;
      out.ray.direction = path2_.cam_from_mirror.Rotate(Reflect(dir, normal)).normalized();
      if (!out.ray.origin.allFinite() || !out.ray.direction.allFinite()) return std::nullopt;
      *blocked = BlockedByMount({Eigen::Vector3d::Zero(), crossing, out.ray.origin}, out.ray);
      return out;
    }
  }
  // Otherwise the ray continues to mirror 1.
  const Eigen::Vector3d origin = path1_.mirror_from_cam.translation;
  const Eigen::Vector3d dir = path1_.mirror_from_cam.Rotate(dir_in_cam);
  double t = 0;
  if (!path1_.sheet.IntersectRay(origin, dir, &t)) return std::nullopt;
  const Eigen::Vector3d s = origin + t * dir;
  if (s.head<2>().squaredNorm() > fixed_.r_sys * fixed_.r_sys) return std::nullopt;
  const Plane<double>& reflex1 = path1_.reflex_in_mirror;
  if (!((s - reflex1.point).dot(reflex1.normal) < 0)) return std::nullopt;  // below the disc
  if (!((origin - reflex1.point).dot(reflex1.normal) > 0)) return std::nullopt;
  const Eigen::Vector3d normal = path1_.sheet.Normal(s);
  if (!(dir.dot(normal) > 0)) return std::nullopt;
  MirrorRay out{Mirror::kOne, Ray{}};
  out.ray.origin = path1_.cam_from_mirror * s;
  out.ray.direction = path1_.cam_from_mirror.Rotate(Reflect(dir, normal)).normalized();
  if (!out.ray.origin.allFinite() || !out.ray.direction.allFinite()) return std::nullopt;
  *blocked = BlockedByMount({Eigen::Vector3d::Zero(), out.ray.origin}, out.ray);
  return out;
}

std::optional<MirrorRay> RigModel::TraceSingle(const Eigen::Vector2d& xy, bool* blocked,
                                               Eigen::Vector3d* camera_dir) const {
  // The camera ray in C: from the pinhole through the undistorted normalised point, or, for a
  // telecentric lens, along the axis through the lateral point (mm).
  const bool telecentric = fixed_.lens == LensKind::kTelecentric;
  const Eigen::Vector3d lens_point =
      telecentric ? Eigen::Vector3d(xy.x(), xy.y(), 0) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d dir_in_cam = telecentric
                                         ? Eigen::Vector3d::UnitZ()
                                         : Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
  if (camera_dir) *camera_dir = dir_in_cam;
  const Eigen::Vector3d origin = path1_.mirror_from_cam * lens_point;
  const Eigen::Vector3d dir = path1_.mirror_from_cam.Rotate(dir_in_cam);
  double t = 0;
  if (!path1_.sheet.IntersectRay(origin, dir, &t)) return std::nullopt;
  const Eigen::Vector3d s = origin + t * dir;
  const double r2 = s.head<2>().squaredNorm();
  if (r2 < fixed_.r_cam * fixed_.r_cam || r2 > fixed_.r_sys * fixed_.r_sys) return std::nullopt;
  const Eigen::Vector3d normal = path1_.sheet.Normal(s);
  if (!(dir.dot(normal) > 0)) return std::nullopt;  // hit from the back
  MirrorRay out{Mirror::kOne, Ray{}};
  out.ray.origin = path1_.cam_from_mirror * s;
  out.ray.direction = path1_.cam_from_mirror.Rotate(Reflect(dir, normal)).normalized();
  if (!out.ray.origin.allFinite() || !out.ray.direction.allFinite()) return std::nullopt;
  *blocked = BlockedByMount({path1_.cam_from_mirror * origin, out.ray.origin}, out.ray);
  return out;
}

}  // namespace omni
