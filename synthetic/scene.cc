#include "synthetic/scene.h"

#include "model/model_derived.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "model/ideal_analysis.h"
#include "model/rig_frames.h"
#include "synthetic/tag_texture.h"

namespace omni::synthetic {
namespace {

// The corners' extent in the target frame: (x_min, y_min, x_max, y_max).
Eigen::Vector4d CornerExtent(const TargetSpec& spec) {
  Eigen::Vector4d e(1e300, 1e300, -1e300, -1e300);
  for (int id : CornerIds(spec)) {
    const Eigen::Vector3d x = CornerInTarget(spec, id);
    e = Eigen::Vector4d(std::min(e[0], x.x()), std::min(e[1], x.y()), std::max(e[2], x.x()),
                        std::max(e[3], x.y()));
  }
  return e;
}

Eigen::Vector3d PatternCentre(const TargetSpec& spec) {
  const Eigen::Vector4d e = CornerExtent(spec);
  return Eigen::Vector3d(0.5 * (e[0] + e[2]), 0.5 * (e[1] + e[3]), 0.0);
}

// Does the segment a -> b pass through the printed sheet (SheetBounds) of placement p?
bool SegmentHitsBoard(const TargetSpec& spec, const Placement& p, const Eigen::Vector3d& a,
                      const Eigen::Vector3d& b) {
  const Eigen::Matrix3d Rt = p.cam_from_target_rotation.transpose();
  const Eigen::Vector3d a_t = Rt * (a - p.cam_from_target_translation);
  const Eigen::Vector3d b_t = Rt * (b - p.cam_from_target_translation);
  if ((a_t.z() > 0) == (b_t.z() > 0)) return false;
  const double s = a_t.z() / (a_t.z() - b_t.z());
  const Eigen::Vector3d x = a_t + s * (b_t - a_t);
  const Eigen::Vector4d sheet = SheetBounds(spec);
  return x.x() > sheet[0] && x.x() < sheet[2] && x.y() > sheet[1] && x.y() < sheet[3];
}

}  // namespace

std::vector<TruthCorner> ComputeTruth(const RigModel& model, const Scene& scene,
                                      const SceneImage& image) {
  std::vector<TruthCorner> out;
  for (size_t pi = 0; pi < image.placements.size(); ++pi) {
    const Placement& p = image.placements[pi];
    const TargetSpec& spec = scene.targets[p.target];
    // The printed side faces -z of the target frame.
    const Eigen::Vector3d front = p.cam_from_target_rotation * Eigen::Vector3d(0, 0, -1);
    for (int id : CornerIds(spec)) {
      TruthCorner t;
      t.placement = static_cast<int>(pi);
      t.target = p.target;
      t.id = id;
      t.point_in_cam = p.cam_from_target_rotation * CornerInTarget(spec, id) +
                       p.cam_from_target_translation;
      for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
        ProjectionInfo info;
        auto px = model.Project(t.point_in_cam, m, &info);
        if (!px) continue;
        const Eigen::Vector3d s = info.point_on_mirror_in_cam;
        if ((s - t.point_in_cam).dot(front) <= 0) continue;  // seen from behind
        bool occluded = false;
        for (size_t qi = 0; qi < image.placements.size() && !occluded; ++qi) {
          if (qi == pi) continue;
          occluded = SegmentHitsBoard(scene.targets[image.placements[qi].target],
                                      image.placements[qi], t.point_in_cam, s);
        }
        if (!occluded) t.pixel[MirrorIndex(m) - 1] = *px;
      }
      out.push_back(t);
    }
  }
  return out;
}

RigParams RigAtImageSize(const RigParams& rig, int width, int height) {
  RigParams out = rig;
  const double s = static_cast<double>(width) / rig.image_width;
  out.image_width = width;
  out.image_height = height;
  out.camera = {s * rig.camera[kFx], s * rig.camera[kFy], s * (rig.camera[kCx] + 0.5) - 0.5,
                s * (rig.camera[kCy] + 0.5) - 0.5, s * rig.camera[kSkew]};
  return out;
}

bool AddRandomImages(const RigModel& model, const RandomPlacement& random, Scene* scene,
                     std::string* error) {
  if (scene->targets.empty()) {
    *error = "no targets defined";
    return false;
  }
  // A physical target is in one place per image: each image draws distinct targets.
  if (random.targets_max > static_cast<int>(scene->targets.size())) {
    *error = "expected at most " + std::to_string(scene->targets.size()) +
             " targets per image (each defined target appears once per image)";
    return false;
  }
  std::mt19937 rng(random.seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  // A single-mirror rig has no stereo region: its targets are seen by its mirror, from 10 deg
  // above its near focus's level to 50 deg below it (where its view allows).
  const bool single = model.params().Single();
  const IdealModel ideal = model.params().Ideal();
  const double single_focus_z = single ? ComputeModelDerived(model.params()).focus1_in_cam.z() : 0;
  for (int i = 0; i < random.images; ++i) {
    SceneImage image;
    char name[32];
    std::snprintf(name, sizeof(name), "%04d", static_cast<int>(scene->images.size()) + 1);
    image.name = name;
    const int n = random.targets_min +
                  static_cast<int>(uni(rng) * (random.targets_max - random.targets_min + 1) * 0.9999);
    const double sector0 = uni(rng) * 2 * M_PI;
    std::vector<bool> used(scene->targets.size(), false);
    for (int k = 0; k < n; ++k) {
      int target = 0;
      do {
        target = static_cast<int>(uni(rng) * scene->targets.size() * 0.9999);
      } while (used[target]);
      used[target] = true;
      const TargetSpec& spec = scene->targets[target];
      bool placed = false;
      for (int attempt = 0; attempt < 200 && !placed; ++attempt) {
        // Targets of one image in separate azimuth sectors so they do not overlap.
        const double az = sector0 + 2 * M_PI * (k + 0.15 + 0.7 * uni(rng)) / n;
        const bool own = static_cast<size_t>(target) < random.target_ranges_mm.size();
        const double lo = own ? random.target_ranges_mm[target].first : random.range_min_mm;
        const double hi = own ? random.target_ranges_mm[target].second : random.range_max_mm;
        const double rho = lo + uni(rng) * (hi - lo);
        // Height between the two foci's levels spread by the range (inside the common FOV).
        const double z_mid = single ? single_focus_z : 0.5 * (ideal.c1 + ideal.d - ideal.c2);
        const double z = single ? z_mid + std::tan((10 - 60 * uni(rng)) * M_PI / 180) * rho
                                : z_mid + (uni(rng) - 0.5) * 0.3 * rho;
        const Eigen::Vector3d centre(rho * std::cos(az), rho * std::sin(az), z);
        // Face the axis: the front (-z_target) points at the rig's axis point at height z_mid.
        const Eigen::Vector3d to_rig = (Eigen::Vector3d(0, 0, z_mid) - centre).normalized();
        Eigen::Vector3d z_axis = -to_rig;
        const Eigen::Vector3d tilt_axis = Eigen::Vector3d(uni(rng) - 0.5, uni(rng) - 0.5, uni(rng) - 0.5).normalized();
        z_axis = Eigen::AngleAxisd(random.max_tilt_rad * uni(rng), tilt_axis) * z_axis;
        Eigen::Vector3d x_axis = Eigen::Vector3d::UnitZ().cross(z_axis);
        if (x_axis.norm() < 1e-6) continue;
        x_axis.normalize();
        x_axis = Eigen::AngleAxisd((uni(rng) - 0.5) * 0.6, z_axis) * x_axis;
        const Eigen::Vector3d y_axis = z_axis.cross(x_axis);
        Placement p;
        p.target = target;
        p.cam_from_target_rotation.col(0) = x_axis;
        p.cam_from_target_rotation.col(1) = y_axis;
        p.cam_from_target_rotation.col(2) = z_axis;
        p.cam_from_target_translation = centre - p.cam_from_target_rotation * PatternCentre(spec);
        // Accept if the four outermost corner positions are seen by both mirrors.
        const Eigen::Vector4d e = CornerExtent(spec);
        bool ok = true;
        for (const Eigen::Vector3d& corner :
             {Eigen::Vector3d(e[0], e[1], 0), Eigen::Vector3d(e[2], e[1], 0),
              Eigen::Vector3d(e[0], e[3], 0), Eigen::Vector3d(e[2], e[3], 0)}) {
          const Eigen::Vector3d x = p.cam_from_target_rotation * corner +
                                    p.cam_from_target_translation;
          ok = ok && model.Project(x, Mirror::kOne) && (single || model.Project(x, Mirror::kTwo));
        }
        if (ok) {
          image.placements.push_back(p);
          placed = true;
        }
      }
      if (!placed) {
        *error = "cannot place a target at ranges " + std::to_string(random.range_min_mm) +
                 ".." + std::to_string(random.range_max_mm) + " mm inside both mirrors' views";
        return false;
      }
    }
    scene->images.push_back(image);
  }
  return true;
}

Placement PlaceFacingAxis(const TargetSpec& spec, int target, const Eigen::Vector3d& centre) {
  const Eigen::Vector3d to_axis = Eigen::Vector3d(-centre.x(), -centre.y(), 0).normalized();
  Placement p;
  p.target = target;
  const Eigen::Vector3d z_axis = -to_axis;
  const Eigen::Vector3d x_axis = Eigen::Vector3d::UnitZ().cross(z_axis).normalized();
  p.cam_from_target_rotation.col(0) = x_axis;
  p.cam_from_target_rotation.col(1) = z_axis.cross(x_axis);
  p.cam_from_target_rotation.col(2) = z_axis;
  p.cam_from_target_translation = centre - p.cam_from_target_rotation * PatternCentre(spec);
  return p;
}

void AddRingImage(const RigModel& model, const RingPlacement& rings, Scene* scene) {
  const IdealModel ideal = model.params().Ideal();
  const DesignParams theta{ideal.c1, ideal.c2, ideal.k1, ideal.k2, ideal.d, ideal.r_sys};
  const FieldOfView fov = ComputeFieldOfView(theta, ideal.r_ref, ideal.r_cam);
  SceneImage image;
  char name[32];
  std::snprintf(name, sizeof(name), "%04d", static_cast<int>(scene->images.size()) + 1);
  image.name = name;
  const int n_ranges = static_cast<int>(rings.ranges_mm.size());
  for (int i = 0; i < n_ranges; ++i) {
    const double rho = rings.ranges_mm[i];
    TargetSpec spec;
    spec.type = TargetType::kChessboard;
    spec.rows = rings.rows;
    spec.cols = rings.cols;
    spec.square_mm = rings.square_at_1m_mm * rho / 1000.0;
    const int target = static_cast<int>(scene->targets.size());
    scene->targets.push_back(spec);
    // Height: the middle of the stereo region at this range (both mirrors' elevation limits).
    const double z_f1 = ideal.c1, z_f2 = ideal.d - ideal.c2;
    const double z_lo = std::max(z_f1 + rho * std::tan(fov.theta1_min), z_f2 + rho * std::tan(fov.theta2_min));
    const double z_hi = std::min(z_f1 + rho * std::tan(fov.theta1_max), z_f2 + rho * std::tan(fov.theta2_max));
    for (int k = 0; k < rings.per_range; ++k) {
      const double az = 2 * M_PI * (k + static_cast<double>(i) / n_ranges) / rings.per_range;
      const Eigen::Vector3d centre(rho * std::cos(az), rho * std::sin(az), 0.5 * (z_lo + z_hi));
      image.placements.push_back(PlaceFacingAxis(spec, target, centre));
    }
  }
  scene->images.push_back(image);
}

std::vector<LipTruth> LipsInCam(const RigParams& rig) {
  std::vector<LipTruth> lips;
  for (int m = 1; m <= 2; ++m) {
    const Lip& lip = m == 1 ? rig.lip1 : rig.lip2;
    const Pose<double> cam_from_mirror =
        PoseFromBlock((m == 1 ? rig.mirror1_pose : rig.mirror2_pose).data());
    LipTruth t;
    t.mirror = m;
    t.color = lip.color;
    t.centre_in_cam = cam_from_mirror * Eigen::Vector3d(0, 0, lip.z);
    t.normal_in_cam = cam_from_mirror.rotation * Eigen::Vector3d::UnitZ();
    t.r_inner = lip.r_inner;
    t.r_outer = lip.r_outer;
    lips.push_back(t);
  }
  return lips;
}

SceneContent ContentOf(const Scene& scene, const SceneImage& image) {
  SceneContent c;
  c.markers = scene.markers;
  for (const Placement& p : image.placements) {
    TargetSheet sheet;
    sheet.cam_from_target_rotation = p.cam_from_target_rotation;
    sheet.cam_from_target_translation = p.cam_from_target_translation;
    sheet.spec = scene.targets[p.target];
    if (sheet.spec.type != TargetType::kChessboard) {
      sheet.texture = TextureFileName(p.target, sheet.spec);
    }
    c.targets.push_back(sheet);
  }
  c.room = scene.room;
  c.room_half_size_mm = scene.room_half_size_mm;
  c.room_floor_mm = scene.room_floor_mm;
  c.room_ceiling_mm = scene.room_ceiling_mm;
  c.room_plain = scene.room_plain;
  c.post_grey = scene.post_grey;
  if (scene.room_texture_seed > 0) {
    // The image's own room: the texture shifted by a few metres, from the seed and the image.
    std::mt19937 rng(scene.room_texture_seed * 7919u + static_cast<unsigned>(
                                                            std::hash<std::string>{}(image.name)));
    std::uniform_real_distribution<double> shift(-5000, 5000);
    c.room_texture_offset_mm = Eigen::Vector3d(shift(rng), shift(rng), shift(rng));
  }
  return c;
}

}  // namespace omni::synthetic
