// The posts of a rig's mount found in its photos: the paper's prototype hangs mirror 1
// over mirror 2 on thin standoffs, which every photo shows as plain radial bands at the same
// azimuths across both rings (detectors/common/views.h's rings: the world seen via each mirror).
//
// What tells a post from the scene: along a ring's elevations a post is one plain surface that
// differs from the columns beside it (post_bands.h: contrast over roughness), in a textured room
// or a plain one, dark or light; the targets move between photos, the posts do not. Each ring of
// each photo is sampled per world azimuth (0.25 deg bins) along its elevations (the model's
// projections of directions from the ring's viewpoint); every band 1.5-12 deg wide is scored, the
// median over the photos kept. A post is a band of the outer ring (mirror 1 carries the posts and
// the lips place its ring) scoring over min_score, confirmed by a band of the inner ring within
// inner_reach_deg (a model not yet calibrated, the design, registers the inner ring a few degrees
// off: the reflex tilt and mirror 2's offsets, which the lips fit later); its edges are the
// half-way crossings of the level step in each photo, their median placing it (azimuth, width)
// and their spread its uncertainty.
//
// Pixel scales: none; the bins are angles and the score a ratio (the noise floor is 1 grey level).
// Failure modes: a post of the room's own level in a plain room shows no contrast; a plain band
// at the same azimuth in both rings in most photos (a door frame at the posts' width) can pass for
// a post: the caller asks for the number of posts it expects, and bands are taken best first.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "model/rig_model.h"

namespace omni::detectors {

struct FoundPost {
  double azimuth = 0;  // rad, world azimuth about the camera's z axis from its x axis
  double width = 0;    // rad, the band's width seen from the axis (its edges' half-way crossings)
  double sigma_azimuth = 0, sigma_width = 0;  // rad: the photos' spread and the bins' quantum
  double score = 0;        // outer ring: contrast over roughness, median over the photos
  double inner_score = 0;  // the inner ring's band near it
  int photos_placed = 0;   // photos whose edges placed it (the others: the band's bins)
};

// A band that scored but was not taken for a post, and why (for the user).
struct RefusedPost {
  double azimuth = 0, width = 0;  // rad
  double score = 0, inner_score = 0;
  std::string why;
};

struct PostSearch {
  std::vector<FoundPost> found;      // at most the count asked for, best first
  std::vector<RefusedPost> refused;  // the best bands left out, best first
  int photos = 0;                    // photos of the model's size looked at
  std::string searched;              // the azimuths both rings were searched over, e.g. "0-360 deg"
};

struct PostFinderOptions {
  double bin_deg = 0.25;
  double min_width_deg = 1.5, max_width_deg = 12;  // a post's band (a wider plain one is a wall)
  double gap_deg = 0.75;       // the band's sides this far out (past the edges' blur)
  int elevations = 32;         // samples along each ring's elevations
  double min_score = 4;        // outer ring: contrast over roughness for a post
  double min_inner_score = 2.5;  // the inner ring's band that confirms it (half of it where the
                                 // outer ring's band scores 3 x min_score)
  double inner_reach_deg = 8;  // the inner ring's band within this of the outer's
  double noise_floor = 1;      // grey levels added to the roughness

  // Empty if the options are usable, else "<field>: expected ...".
  std::string Check() const;
};

// Grey images (CV_8U or 16U, the model's size; others are passed over). Up to `count` posts, best
// first, and the bands refused with why.
PostSearch SearchPosts(const std::vector<cv::Mat>& grey_images, const RigModel& model, int count,
                       const PostFinderOptions& options = {});
// SearchPosts(...).found.
std::vector<FoundPost> FindPosts(const std::vector<cv::Mat>& grey_images, const RigModel& model,
                                 int count, const PostFinderOptions& options = {});

// A post's side (mm) from its band's width (rad) seen from the axis at `radius` (mm): the near
// face's corners at radius - side / 2 span the band.
double PostSideFromBand(double band_width, double radius);

// Where the model has a mount and the photo (grey) shows all of its posts turned by one angle
// of over min_turn_deg (they agree within 0.5 deg: a photo of another rig, or a mount turned since
// the model was made), that angle (rad, + counter-clockwise about the camera's z). nullopt
// otherwise: posts where the model says, or a photo that shows fewer of them or posts that
// disagree among themselves (a target can hide a post).
std::optional<double> MountTurnInPhoto(const cv::Mat& grey, const RigModel& model,
                                       double min_turn_deg = 1.0);

// The photo's posts against the model's mount, one search (FindPosts for two more than the
// model has): the mount turned (MountTurnInPhoto's answer; then nothing else is said), posts the
// photo shows where the model has none (farther than `tolerance_deg` plus half the band from
// every model post) and the model's posts the photo shows none at (within the same reach; a
// target in front of a post hides it too, so this is said, not acted on).
struct MountInPhoto {
  std::optional<double> turn;             // rad
  std::vector<FoundPost> unexpected;      // best first
  std::vector<int> unseen;                // indices into mount.azimuths
};
MountInPhoto CompareMountWithPhoto(const cv::Mat& grey, const RigModel& model,
                                   double tolerance_deg = 2.0, double min_turn_deg = 1.0);

}  // namespace omni::detectors
