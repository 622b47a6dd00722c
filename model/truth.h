// What a synthetic session's truth says (the `omnistereo-truth/1` file that `render` writes beside
// its images, synthetic/scene_file.h TruthText; read by io/truth_file.h; computed by
// synthetic/scene.h ComputeTruth): per image, the target placements and every target corner's
// point in C and its exact pixel in each ring. `calibrate --truth`, the triangulation experiment
// (stereo/sparse_triangulation.h), bench/eval_detectors and the detector tests compare
// detections with it through one matcher, NearestTrueCorner.
#pragma once

#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/types.h"

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

// A published table of triangulation error to compare with, by range (e.g. the paper's
// tab:rmse_triangulation_experiment, kept in bench/paper_triangulation_table.csv; `triangulate
// --reference_table`, read by io/truth_file.h). A row applies to the range bins within 10% of
// its range (stereo/sparse_triangulation.h).
struct ReferenceRow {
  double range_m = 0, rmse_mm = 0, sd_mm = 0;
};

// The true corner a detection is, judged by its pixels alone (independent of any model): among
// the corners `admit` accepts (all if empty) that are seen in every ring the detection has a
// pixel in, the one whose distance (the larger of its rings' distances) is least and below
// max_px; the first of equals. corner is nullptr when none is.
struct TrueCornerMatch {
  const TruthCorner* corner = nullptr;
  double distance_px = HUGE_VAL;
};
TrueCornerMatch NearestTrueCorner(const std::vector<TruthCorner>& corners,
                                  const std::optional<Eigen::Vector2d> (&pixel)[2],
                                  double max_px = HUGE_VAL,
                                  const std::function<bool(const TruthCorner&)>& admit = {});
// One ring's detection (pixel seen via `mirror`).
TrueCornerMatch NearestTrueCorner(const std::vector<TruthCorner>& corners, Mirror mirror,
                                  const Eigen::Vector2d& pixel, double max_px = HUGE_VAL,
                                  const std::function<bool(const TruthCorner&)>& admit = {});

}  // namespace omni
