// What a synthetic session's truth says (the `omnistereo-truth/1` file that `render` writes beside
// its images, synthetic/scene_file.h TruthText; read by io/truth_file.h): per image, the
// target placements and every target corner's point in C and its exact pixel in each ring. The
// triangulation experiment (stereo/sparse_triangulation.h) and `calibrate --truth_model`
// compare against it.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace omni {

struct TruthCorner {
  int placement = 0, target = 0, id = 0;
  Eigen::Vector3d point_in_cam = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector2d> pixel[2];  // [0] mirror 1, [1] mirror 2
};

struct TruthImage {
  std::string file;
  std::vector<Eigen::Vector3d> placement_translation;  // cam_from_target translations, mm
  std::vector<TruthCorner> corners;
};

struct Truth {
  std::string model;  // the model file the session was rendered with
  std::vector<TruthImage> images;
};

}  // namespace omni
