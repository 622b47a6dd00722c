// The posts of a rig's mount found in its photos: the paper's prototype hangs mirror 1
// over mirror 2 on thin standoffs, which every photo shows as plain radial bands at the same
// azimuths across both rings (detectors/common/views.h's rings: the world seen via each mirror).
//
// What tells a post from the scene: along a ring's elevations a post is one matte surface (its
// profile along the ring's radius nearly flat), the scene is texture; the targets move between
// photos, the posts do not. Per world azimuth (0.5 deg bins) and ring, the spread of the grey
// levels along the ring's elevations (the model's projections of directions from the ring's
// viewpoint), relative to the median over azimuths of that photo and ring; the median over the
// photos and the mean over both rings is the azimuth's score. A post is a run of bins scoring
// under kPostScore (both rings flat there in most photos) no wider than max_width_deg.
//
// Pixel scales: none; the bins are angles and the score a ratio. Failure modes: a scene with
// large plain areas at the same azimuth in both rings in most photos (a bare wall at the posts'
// width) can pass for a post: the caller asks for the number of posts it expects, and the runs
// are returned deepest first.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "model/rig_model.h"

namespace omni::detectors {

struct FoundPost {
  double azimuth = 0;  // rad, world azimuth about the camera's z axis from its x axis
  double width = 0;    // rad, the run of flat bins
  double score = 0;    // the run's lowest score (0: flat in every photo; 1: the scene's median)
};

struct PostFinderOptions {
  double bin_deg = 0.5;
  double max_score = 0.35;      // a bin under this is flat enough for a post
  double max_width_deg = 12;    // a wider flat run is scene (a wall), not a post
  int elevations = 24;          // samples along each ring's elevations
  double registration_deg = 1;  // each elevation step taken as the flattest within +-this
  double min_texture = 2;       // grey levels: a photo's ring whose median spread is under this
                                // has no texture to tell posts by

  // Empty if the options are usable, else "<field>: expected ...".
  std::string Check() const;
};

// Grey images (CV_8U or 16U, the model's size). Up to `count` posts, deepest first (fewer if
// fewer runs qualify).
std::vector<FoundPost> FindPosts(const std::vector<cv::Mat>& grey_images, const RigModel& model,
                                 int count, const PostFinderOptions& options = {});

// Where the model has a mount and the photo (grey) shows all of its posts turned by one angle
// of over min_turn_deg (they agree within 0.5 deg: a photo of another rig, or a mount turned since
// the model was made), that angle (rad, + counter-clockwise about the camera's z). nullopt
// otherwise: posts where the model says, or a photo that shows fewer of them or posts that
// disagree among themselves (a target can hide a post).
std::optional<double> MountTurnInPhoto(const cv::Mat& grey, const RigModel& model,
                                       double min_turn_deg = 1.0);

}  // namespace omni::detectors
