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
//
// Scale and failure modes, in short: meant for small tags (the inner ring's 1.4-2 raw px per
// bit) under a camera's blur (fitted from 0.8 px, clamped to 0.1-3 px). The fit returns nothing
// where the ring's map holds too little of the region (under 30 of its 81 samples) or the region
// leaves the image, under 40 pixels remain, the fitted contrast is under min_contrast, the rms
// misfit exceeds max_misfit of the contrast, or a corner moves more than max_shift_px (1.5 raw
// px). AlignTargetPattern returns nothing for a target the view's map does not hold whole, a
// template over 400 view px, a best correlation under min_score (0.5), or a runner-up half a
// pitch away too close to tell the grid's shift.
#pragma once

#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "detectors/common/views.h"
#include "model/target.h"

namespace omni::detectors {

struct TagPatternFitOptions {
  int samples_per_bit = 8;          // the pattern's render on the target plane
  double reach_into_gap = 0.75;     // pixels fitted out to this fraction of the gap around the tag
  double max_shift_px = 1.5;        // a corner moved farther from its start: no fit
  double max_misfit = 0.12;         // rms misfit / fitted contrast above this: no fit
  double min_contrast = 0.05;       // fitted white - black (grey image's units)
  int max_iterations = 25;  // per round
  int max_rounds = 5;        // of the blur's update (each round fits at the blur the last one found)
  // A cubic tone curve between the levels (value = black + contrast b + t1 b (1 - b) + t2 b (1 -
  // b) (1 - 2 b), b the blurred pattern): what a camera's demosaicing does to the levels near
  // edges, which linear levels alone read as the tag shrinking (OpenCV's edge-aware demosaic in
  // the realistic camera: -0.018 px per corner towards the tag's centre in hid1's ring 2, -0.006
  // with these terms; the mechanism is not pinned down: a sharpened, black-clipped synthetic
  // tag is not helped by them).
  bool tone_terms = true;
  int max_pixels = 0;  // > 0: a larger region fitted on a regular subset of its pixels
};

struct TagPatternFit {
  Eigen::Vector2d corners[4];  // raw pixels, k order (model/target.h CornerInTarget)
  double sigma_px = 0;         // the fitted blur (raw px, Gaussian; the pixel's box apart)
  double misfit = 0;           // rms misfit / contrast
  int pixels = 0;              // raw pixels fitted
};

// A tag grid's whole printed pattern located in a view from a rough plane -> view homography
// (guided detection's prediction from the other ring: 10-25 raw px off through the ideal design of
// a misaligned rig, more than a pitch of the inner ring's smallest tags, whose junctions are too
// close for saddle points). The pattern over its tags and most of the gaps round them, rendered
// through the prediction at the view's blur, is correlated with the view (TM_CCOEFF_NORMED) over
// translations within `radius_view_px`; the best must beat every translation half a pitch or more
// from it by `min_margin`. Then the whole pattern is fitted to the raw pixels (as FitTagPattern
// fits one tag) with the homography of its outer tag corners free.
struct TargetAlignOptions {
  double min_score = 0.5;    // the best translation's correlation
  double min_margin = 0.1;   // best - best half a pitch or more away
  // Under min_margin (but at least min_margin_to_fit) the pattern is fitted at both and the
  // runner-up's misfit must be this many times the best's (or its fit fail, or land at the best).
  double min_margin_to_fit = 0.03;
  double min_misfit_ratio = 1.5;
  double max_misfit = 0.15;  // the whole pattern's fit (rms / contrast)
  // The fitted outer corners from the correlation's (the prediction's scale and turn are off
  // too: 4-7 view px in hid1's inner ring), in tag pitches.
  double max_shift_pitches = 0.25;
  int max_fit_pixels = 2500;
  // Scales 0.92-1.08 and turns of +-4 deg of the prediction tried; false: translations alone (a
  // prediction whose scale and turn are already right, e.g. fitted to the target's junctions).
  bool search_similarity = true;
};
struct TargetAlignment {
  Eigen::Matrix3d view_from_plane = Eigen::Matrix3d::Identity();  // plane mm (CornerInTarget) -> view
  double score = 0, second = 0, misfit = 0;
};
std::optional<TargetAlignment> AlignTargetPattern(const cv::Mat& grey, const RingView& view,
                                                  const TargetSpec& target,
                                                  const Eigen::Matrix3d& view_from_plane_mm,
                                                  double radius_view_px,
                                                  const TargetAlignOptions& options = {});

// Tag `tag_id` (absolute id; plain or Kalibr) of `target` in `view` of a grey CV_32F raw image, its corners
// approximately at `corners_in_view` (view pixels, k order). nullopt where the tag's pixels leave
// the image or the view's map, or the fit fails its checks (options).
std::optional<TagPatternFit> FitTagPattern(const cv::Mat& grey, const RingView& view,
                                           const TargetSpec& target, int tag_id,
                                           const Eigen::Vector2d (&corners_in_view)[4],
                                           const TagPatternFitOptions& options = {});

}  // namespace omni::detectors
