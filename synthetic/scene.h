// Synthetic sessions: what is in front of the rig in each image (targets with their poses,
// markers, a room) and the exact ground truth our model gives for it. The same truth serves the
// fast path (no rendering, for unit tests) and the POV-Ray renders.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/rig_model.h"
#include "model/target.h"
#include "model/truth.h"
#include "synthetic/camera_effects.h"
#include "synthetic/pov_scene.h"

namespace omni::synthetic {

// Targets (kinds, corner ids, corner positions, printed sheet) are model/target.h's TargetSpec.

struct Placement {
  int target = 0;  // index into Scene::targets
  Eigen::Matrix3d cam_from_target_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d cam_from_target_translation = Eigen::Vector3d::Zero();
};

struct SceneImage {
  std::string name;
  std::vector<Placement> placements;
};

// How to fill a scene with random target placements: `images` images with targets_min..max
// distinct targets each (at most as many as the scene defines), at horizontal ranges range_min..range_max (mm) from the axis, inside the stereo
// region (the target's centre is seen by both mirrors), facing the rig within +-max_tilt.
struct RandomPlacement {
  int images = 0;
  int targets_min = 1, targets_max = 3;
  double range_min_mm = 500, range_max_mm = 2000;
  // Optional, one per target: its own [min, max] range (small near targets, big far ones).
  std::vector<std::pair<double, double>> target_ranges_mm;
  double max_tilt_rad = 0.35;
  unsigned seed = 1;
};

// The paper's sparse triangulation scene (tab:rmse_triangulation_experiment): `per_range`
// chessboards at each horizontal range, spread in azimuth, facing the axis, centred in height in
// the stereo region, with the square scaled with range (square_at_1m * range / 1 m).
struct RingPlacement {
  std::vector<double> ranges_mm;
  int per_range = 4;
  int rows = 4, cols = 5;
  double square_at_1m_mm = 40.0;
};

struct Scene {
  int width = 0, height = 0;  // 0: the model's image size
  bool antialias = true;
  double noise_sigma = 0.0;   // grey levels (0..255) of Gaussian sensor noise
  unsigned noise_seed = 1;
  CameraEffects camera;       // what the camera adds after POV-Ray (`camera_effects:`)
  bool room = false;
  double room_half_size_mm = 3000, room_floor_mm = -1200, room_ceiling_mm = 1800;
  bool room_plain = false;     // `room.texture: plain` (a textureless room)
  unsigned room_texture_seed = 0;  // > 0: each image sees the texture shifted by its own offset
  double post_grey = 0.25;     // `posts.grey`: the mount's posts' paint (0 black .. 1 white)
  std::vector<TargetSpec> targets;  // as in the session file's `targets:`
  std::vector<SceneImage> images;
  std::vector<Marker> markers;  // drawn in every image
};

// The same rig and camera imaged at another size with the same aspect ratio (the scene's
// `image:`): fx, fy, skew scale by width / rig.image_width and the principal point about the
// pixel-centre convention, c' + 0.5 = s (c + 0.5); distortion (normalised coordinates) is kept.
RigParams RigAtImageSize(const RigParams& rig, int width, int height);

// Appends random images to scene->images (deterministic for a seed). Returns false with a reason
// if a placement in the stereo region cannot be found (e.g. ranges outside what the rig sees).
bool AddRandomImages(const RigModel& model, const RandomPlacement& random, Scene* scene,
                     std::string* error);

// A placement of `target` with its pattern centred at `centre` (C) and its printed side facing the
// rig's axis horizontally: target x tangential, target y along +z of C.
Placement PlaceFacingAxis(const TargetSpec& spec, int target, const Eigen::Vector3d& centre);

// Adds one image with the ring placements (and a target definition per range).
void AddRingImage(const RigModel& model, const RingPlacement& rings, Scene* scene);

// Ground truth of each corner of the image's placements (model/truth.h TruthCorner): its point in
// C and its pixel via each mirror (nullopt where the model says invalid, the target faces away
// from that mirror, or another target occludes it).
std::vector<TruthCorner> ComputeTruth(const RigModel& model, const Scene& scene,
                                      const SceneImage& image);

// A lip (flat coloured annulus at a mirror's rim) as its two boundary circles in C, the mirror's
// pose applied: centre, unit normal (the mirror body's +z), radii. What the lip detector images.
struct LipTruth {
  int mirror = 1;
  std::string color;
  Eigen::Vector3d centre_in_cam = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal_in_cam = Eigen::Vector3d::UnitZ();
  double r_inner = 0, r_outer = 0;
};

// Both lips of the rig (mirror 1's, then mirror 2's).
std::vector<LipTruth> LipsInCam(const RigParams& rig);

// The POV-Ray content of one image of the scene.
SceneContent ContentOf(const Scene& scene, const SceneImage& image);

}  // namespace omni::synthetic
