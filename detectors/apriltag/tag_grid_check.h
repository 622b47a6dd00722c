// Grid check for tag corners refined in the raw image: the corners of one target seen in one
// ring must lie on the target's image.
//
// In a ring view (views.h) a planar target is seen by a pinhole, so its corners are a homography
// of their positions on the target plane (CornerInTarget), exact to about 0.01 px for the views'
// rays at 0.5-2 m (the chessboards' grid check measured it on ComputeTruth corners). A corner
// whose refinement window was cut by the ring's edge (a Kalibr corner next to the ring's rim: the
// window takes in the rim's dark edge and moves the corner 1.5-3 raw px) does not fit that
// homography, while its id is right: such a corner is dropped (an id is right or absent, and a
// corner that cannot be measured honestly is better absent than wrong by 2 px).
//
// Each corner is judged in its own tag's view: all corners of the target found in the same ring
// are taken back into that view (RawToView), a homography is fitted by RANSAC and then least
// squares on the corners within the tolerance, and the corner's residual is measured in RAW
// pixels (the views magnify the inner ring 2-3 times).
//
// Failure modes: a target with fewer than max(5, min_corners) corners in a ring is not checked
// (its corners are kept); a corner off by less than the tolerance stays.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "detectors/common/views.h"
#include "model/rig_model.h"
#include "model/target.h"

namespace omni::detectors {

struct TagGridCheckOptions {
  double max_residual_px = 0.5;  // raw pixels from the fitted homography's prediction
  // Fewer corners than this in a view (a lone tag: 4 corners fix a homography exactly) cannot be
  // checked; they are kept or dropped by `keep_unchecked`.
  int min_corners = 8;
  bool keep_unchecked = true;

  // Empty if the options are usable, else "<field>: expected ...".
  std::string Check() const;
};

// One corner of a target in one ring: where it is on the target plane, its refined raw pixel,
// and the view its tag was found in (index into the views).
struct GridCorner {
  Eigen::Vector2d in_target = Eigen::Vector2d::Zero();  // mm, CornerInTarget's x, y
  Eigen::Vector2d raw = Eigen::Vector2d::Zero();
  int view = 0;
};

// The verdict on one corner.
struct GridFit {
  bool keep = true;          // fits (or unchecked and options.keep_unchecked)
  double residual_px = -1;   // raw pixels from the prediction; -1: not checked
  // Where the homography fitted to the OTHER fitting corners puts this corner, in its tag's view
  // and in the raw image (valid only if checked).
  Eigen::Vector2d predicted_in_view = Eigen::Vector2d::Zero();
  Eigen::Vector2d predicted_raw = Eigen::Vector2d::Zero();
};

// Per corner (same order): does it fit the target's homography? All corners must belong to ONE
// target seen in ONE ring.
std::vector<GridFit> CornersFittingTargetHomography(const std::vector<RingView>& views,
                                                    const RigModel& model,
                                                    const std::vector<GridCorner>& corners,
                                                    const TagGridCheckOptions& options = {});

}  // namespace omni::detectors
