// Natural-feature matches between the two rings of one image (the in-field check).
//
// A point of the scene seen in both rings must satisfy the rig's geometry: its ring-2 image lies
// on the epipolar curve of its ring-1 ray. To test that, a match must NOT be sought along that
// curve only (it would then lie on it by construction). So: the panoramas and SGBM's disparity
// along the columns (stereo/dense_stereo.h) under the stored model give each reference
// feature of Xi_1 a starting match in Xi_2; a pyramidal Lucas-Kanade track from Xi_1 to Xi_2
// started there is free in both directions, so a rig that has moved since its calibration shows
// as a sideways (azimuthal) offset of the match. A match is kept if the track converged, stayed
// within max_offset_px of its start, and the track back from Xi_2 returns to the feature within
// max_round_trip_px, and neither end lies within a window of a post's sector (the model's mount:
// the LUT's invalid columns). Panorama pixels map to raw pixels through the LUTs (bilinear), so what the
// caller gets is exact raw pixels of both rings, free of the panorama's cylinder approximation.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_model.h"

namespace omni::health {

struct RingMatch {
  Eigen::Vector2d pixel1 = Eigen::Vector2d::Zero();  // raw pixel via mirror 1 (outer ring)
  Eigen::Vector2d pixel2 = Eigen::Vector2d::Zero();  // raw pixel via mirror 2 (inner ring)
  double azimuth = 0;    // rad, of the feature's panorama column (panorama.h)
  double elevation = 0;  // rad, of the feature's Xi_1 row
  double sideways_px = 0;  // the track's column offset in the panoramas (diagnostic)
};

struct RingMatchOptions {
  int panorama_width = 0;  // 0: the image's width (about ring 1's circumference in pixels)...
  // ...up to this: the window and thresholds below are set for 1280-1600 px panoramas. A 5 MP
  // image's full width (2592) spreads its blur over twice the pixels: 259 matches of one photo
  // where 1600 px gave 953 (docs/experiments.md, 2026-11-28).
  int max_panorama_width = 1600;
  int max_features = 4000;
  double quality_level = 0.005;   // cv::goodFeaturesToTrack, relative to the strongest corner
  double min_distance_px = 5;     // between features (panorama px)
  int window_px = 15;             // Lucas-Kanade window (odd)
  int pyramid_levels = 1;
  double max_offset_px = 4;       // from SGBM's start, either direction (panorama px)
  double max_round_trip_px = 0.2;
  // No match within half a window plus this of a post's sector in either ring (the mount's
  // model may be off by a little: a post 0.5 mm wider at 41.5 mm is 0.7 deg).
  double mount_margin_deg = 1.5;
};

class RingMatcher {
 public:
  // Builds the panoramas' look-up tables for the stored model (the expensive, once-per-model part).
  explicit RingMatcher(const RigModel& model, const RingMatchOptions& options = {});
  ~RingMatcher();

  // Matches in one image (8-bit grey or BGR of the model's size; throws std::invalid_argument
  // otherwise).
  std::vector<RingMatch> Match(const cv::Mat& image) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace omni::health
