// The rim of a single mirror in its photos: the circle where the mirror's image ends, which a
// camera nobody designed for us shows in every photo at the same place (the start of its
// calibration: model/central_mirror.h turns the rim's image radius and the mirror's measured
// diameter into the rig's scale).
//
// What tells the rim: it is the strongest circular edge of the photos with the mirror's image
// (the scene, bright on average) inside and the housing (dark) outside, the same in every photo.
// The photos' per-pixel median keeps it and blurs what moves (targets, the photographer). A
// coarse search over centres near the image centre and radii scores each circle by the mean
// brightness drop across it (inside minus outside) times the share of its samples where the drop
// is clear; the best circle is refined on the full-resolution median: per ray from its centre, the
// steepest drop within a band about the coarse radius (sub-pixel by a parabola), then a circle
// fitted to those edge points with Huber weights (rays crossed by a holder or a post drop out).
//
// Pixel scales: the coarse search runs at about 320 px across; the refinement band is 4% of the
// radius; nothing is tied to one image size. Failure modes: a mirror whose image is darker than
// its housing (inside_brighter false finds it), a rim mostly outside the image (coverage low:
// refused), the camera's own dark reflection at the centre (its polarity is the opposite).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace omni::detectors {

struct MirrorRimOptions {
  // The rim's radius as a fraction of half the image's shorter side: the search range.
  double min_radius_fraction = 0.3, max_radius_fraction = 1.2;
  // The centre's search window about the image centre, as a fraction of the shorter side.
  double centre_window_fraction = 0.2;
  bool inside_brighter = true;
  int rays = 720;
  // A fit is refused below this share of rays with an edge (the rim mostly hidden or outside
  // the image) or above this rms of the edge points about the circle (px).
  double min_coverage = 0.5;
  double max_rms_px = 1.5;
  // Empty if consistent, else "<field>: expected ...".
  std::string Check() const;
};

struct MirrorRim {
  bool found = false;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // px, image coordinates
  double radius_px = 0;
  double rms_px = 0;       // the edge points' radial residuals about the circle
  double coverage = 0;     // share of rays whose edge point was used
  int edge_points = 0;
  double contrast = 0;     // grey levels: the median brightness drop across the rim
  std::string why;         // when not found: what was missing
};

// Grey images (CV_8U or CV_16U, one size). Throws std::invalid_argument for no images, images of
// different sizes or options that fail Check().
MirrorRim FindMirrorRim(const std::vector<cv::Mat>& grey_images,
                        const MirrorRimOptions& options = {});

}  // namespace omni::detectors
