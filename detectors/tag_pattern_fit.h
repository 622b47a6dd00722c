// A plain tag's corners from all of its pixels: the target's printed pattern (the tag's code
// cell by cell, the white gaps, the neighbouring tags' borders) mapped into the raw image through
// a plane -> view homography and the view's map, blurred by a Gaussian, and fitted to the raw
// pixels over the tag and most of the gap around it (Gauss-Newton on the homography's four view
// corners, the black and white levels and the blur).
//
// Why: in the inner ring of a camera image a tag36h11 bit is 1.4-2 raw px and the defocus
// (sigma 0.9 px) spreads every edge over the bits behind it, so the edge fit (RefineTagCorners:
// each border edge with the bit behind it as a bar) erred ~0.1 px per corner even without noise
// (hid1 session, defocus alone). The pattern is known exactly once the tag is read; every bit
// edge inside it carries the geometry too.
#pragma once

#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "detectors/views.h"
#include "model/target.h"

namespace omni::detectors {

struct TagPatternFitOptions {
  int samples_per_bit = 8;          // the pattern's render on the target plane
  double reach_into_gap = 0.75;     // pixels fitted out to this fraction of the gap around the tag
  double max_shift_px = 1.5;        // a corner moved farther from its start: no fit
  double max_misfit = 0.12;         // rms misfit / fitted contrast above this: no fit
  double min_contrast = 0.05;       // fitted white - black (grey image's units)
  int max_iterations = 25;
  // A cubic tone curve between the levels (value = black + contrast b + t1 b (1 - b) + t2 b (1 -
  // b) (1 - 2 b), b the blurred pattern): what a camera's demosaicing does to the levels near
  // edges, which linear levels alone read as the tag shrinking (OpenCV's edge-aware demosaic in
  // the realistic camera: -0.018 px per corner towards the tag's centre in hid1's ring 2, -0.006
  // with these terms; the mechanism is not pinned down: a sharpened, black-clipped synthetic
  // tag is not helped by them).
  bool tone_terms = true;
};

struct TagPatternFit {
  Eigen::Vector2d corners[4];  // raw pixels, k order (model/target.h CornerInTarget)
  double sigma_px = 0;         // the fitted blur (raw px, Gaussian; the pixel's box apart)
  double misfit = 0;           // rms misfit / contrast
  int pixels = 0;              // raw pixels fitted
};

// Plain tag `tag_id` (absolute id) of `target` in `view` of a grey CV_32F raw image, its corners
// approximately at `corners_in_view` (view pixels, k order). nullopt where the tag's pixels leave
// the image or the view's map, or the fit fails its checks (options).
std::optional<TagPatternFit> FitTagPattern(const cv::Mat& grey, const RingView& view,
                                           const TargetSpec& target, int tag_id,
                                           const Eigen::Vector2d (&corners_in_view)[4],
                                           const TagPatternFitOptions& options = {});

}  // namespace omni::detectors
