// The mount that holds a built rig together: the paper's prototype hangs mirror 1 over
// mirror 2 on three thin standoffs instead of a glass tube. Each post is a square prism of side
// `width` (or each its own: `widths`, a prototype's standoffs need not match) standing parallel to
// the body's axis at distance `radius` from it, one face towards the axis, from z_min to z_max, in
// the body frame of the mirror it is fixed in (`body`, mirror 1 by
// default: the standoffs are screwed into mirror 1's rim and carry it, so a tilt of mirror 1
// against mirror 2 moves the posts with mirror 1).
//
// A light path that crosses a post is blocked: the rig's projection and unprojection treat it
// like a path outside a ring (invalid), so panoramas, depth and everything built on RigModel
// leave the posts' sectors out.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "model/rig_frames.h"
#include "model/types.h"

namespace omni {

struct Mount {
  bool present = false;
  Mirror body = Mirror::kOne;
  double width = 0, radius = 0;    // mm; width: every post's side where `widths` is empty
  double z_min = 0, z_max = 0;     // mm, in the body frame
  std::vector<double> azimuths;    // rad, about the body's z axis from its x axis
  std::vector<double> widths;      // mm, post i's side (empty: all `width`; else one per azimuth)

  // Post i's side (mm), and the widest post's.
  double WidthOf(size_t i) const { return i < widths.size() ? widths[i] : width; }
  double MaxWidth() const;
  // Whether every post has the same side (`width:` in the model file, not `widths:`).
  bool EqualWidths() const;
};

// Whether the segment a -> b (both in C) passes through a post; cam_from_body: the body's pose.
bool SegmentHitsMount(const Mount& mount, const Pose<double>& cam_from_body,
                      const Eigen::Vector3d& a_in_cam, const Eigen::Vector3d& b_in_cam);

// Whether two posts overlap (their squares meet: centres closer than the mean of their widths
// times sqrt(2)).
bool PostsOverlap(const Mount& mount);

}  // namespace omni
