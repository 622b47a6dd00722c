// Reading `omnistereo-design/1` YAML files: the input of `omnistereo design`
// (sample_configs/big_rig_design.yaml is the annotated example). Keys:
//   format: omnistereo-design/1
//   search_box: {lower: {c1, c2, k1, k2, d, r_sys}, upper: {...}}       mm, k unitless
//   constraints: {k_ratio_min, mass_max_g, mass_model: authors|full, h_sys_max,
//                 vertex_offset_min, theta1_max_limit_deg, theta1_max_sense: at_least|at_most,
//                 theta1_min_limit_deg, theta2_min_limit_deg}
//   mass: {mirror_wall_mm, mirror_density, camera_mass_g, tube_wall_mm, tube_density}  optional
//   r_cam: 7.0                                          hole radius of mirror 2, mm
//   camera: {fx, fy, cx, cy, skew (optional)}           intrinsics of the written model
//   image: {width, height}
//   solver: {starts, max_evaluations_per_start}         optional
//   start: {c1, c2, k1, k2, d, r_sys}                   optional extra first starting point
#pragma once

#include <string>

#include "design/optimizer.h"
#include "io/model_file.h"
#include "model/camera.h"

namespace omni::design {

struct DesignConfig {
  OptimizerOptions options;
  Pinhole<double> camera{1450.0, 1450.0, 639.5, 479.5, 0.0};
  int image_width = 1280, image_height = 960;
};

// Throws io::InputError naming the file and the key for: a missing or unreadable file, malformed YAML,
// a format other than omnistereo-design/1.x, a missing required key, a value that is not a finite
// number, k <= 2, c <= 0, d <= 0, r_sys <= 0, a lower bound above its upper bound, r_cam <= 0,
// non-positive focal lengths or image size, an unknown enum word.
DesignConfig ReadDesignConfig(const std::string& path);

}  // namespace omni::design
