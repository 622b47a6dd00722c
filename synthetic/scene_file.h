// The scene file `omnistereo-scene/1` (YAML) and the ground-truth file `omnistereo-truth/1`.
//
//   format: omnistereo-scene/1
//   image: {width: 1280, height: 960}          # optional: the model's size
//   render: {antialias: true, noise_sigma: 0.0, noise_seed: 1}
//   camera_effects: realistic        # or {preset: realistic, defocus_sigma_px: [0.6, 0.9], ...}
//   room: {enabled: true, half_size: 3000, floor: -1200, ceiling: 1800}     # mm, z_C up
//   posts: {grey: 0.25}                       # the model mount's posts: paint, 0 black .. 1 white
//   targets: [{type: chessboard, rows: 6, cols: 8, square: 40.0}]
//   images:                                   # explicit placements (cam_from_target) ...
//     - {name: "0001", placements: [{target: 0, rotation: [rx, ry, rz], translation: [x, y, z]}]}
//   random: {images: 20, targets: [1, 3], range: [500, 2000], max_tilt_deg: 20, seed: 7}  # ... or
//   rings: {ranges: [250, 500, 1000], per_range: 4, rows: 4, cols: 5, square_at_1m: 40}  # or
//   markers: [{center: [x, y, z], radius: 5.0}]
#pragma once

#include <optional>
#include <string>

#include "synthetic/scene.h"

namespace omni::synthetic {

// Reads a scene file; random images are generated with the model. Throws io::InputError naming
// the file and key.
Scene ReadSceneFile(const std::string& path, const RigModel& model);

// `camera_effects:` from YAML text (a preset name or a map, as in the scene file); `what` names
// the source in errors.
CameraEffects ParseCameraEffects(const std::string& text, const std::string& what);
// The camera named by the environment variable `variable` (the benches' EVAL_CAMERA: a preset
// name or a YAML map, ParseCameraEffects), nullopt when it is not set.
std::optional<CameraEffects> CameraFromEnvironment(const char* variable);

// The ground-truth file of a rendered (or fast-path) session: per image the target poses and per
// corner [placement, target, id, x, y, z, u1, v1, u2, v2] with null where not visible.
std::string TruthText(const Scene& scene, const RigModel& model, const std::string& model_file);

}  // namespace omni::synthetic
