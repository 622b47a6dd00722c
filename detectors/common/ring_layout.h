// Which raw-image pixels belong to which part of the rig, predicted from a model (the ideal one is
// enough): mirror 1's OUTER ring, mirror 2's INNER ring (seen through the reflex disc), the two
// coloured lip bands and the hole of mirror 2.
//
// Every boundary is the image of a 3D circle of the rig, projected along its optical path:
//   hole         mirror 2's hole rim (r_cam)       -> reflex plane -> camera   (inner edge of ring 2)
//   mirror2_rim  mirror 2's rim (r_sys)            -> reflex plane -> camera   (outer edge of ring 2)
//   lip2_outer   the red lip's outer circle        -> reflex plane -> camera
//   reflex_edge  the reflex disc's rim (r_ref)     -> camera                   (outer edge of
//                                                                               what the disc shows)
//   mirror1_cut  where mirror 1 meets the reflex plane -> camera (mirror 1 exists only beyond the
//                plane, rig_model.h; on a misaligned rig this curve and reflex_edge differ and ring 1
//                starts at the outer of the two)
//   mirror1_rim  mirror 1's rim (r_sys)            -> camera                   (outer edge of ring 1)
//   lip1_outer   the blue lip's outer circle       -> camera
// The mirrors also reflect the undersides of their own lips just inside their rims (docs/design.md, Conventions),
// so the last few pixels inside mirror?_rim show a lip, not the world: the label there is still
// the mirror's; the lip detector separates those images.
// Each boundary is a closed curve around `centre`, stored as its radius at evenly spaced polar
// angles about `centre` (the curves are near-circles, star-shaped about the axis's image).
//
// Pixel scales: raw pixels, only as exact as the model: a design (not yet calibrated) puts the
// boundaries 10-20 px off on a built rig (lip_guide.h). Failure modes: none of its own; a model
// of another rig or size gives another layout (the image is checked against the model's size
// by the callers, detect_session.h).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_model.h"

namespace omni::detectors {

// A closed image curve r(phi) around a centre; phi = atan2(v - cv, u - cu).
struct RingBoundary {
  std::vector<double> radius;  // radius[k] at phi = -pi + 2 pi k / radius.size()
  double RadiusAt(double phi) const;
  double MinRadius() const;
  double MaxRadius() const;
};

enum class RingLabel : std::uint8_t {
  kNone = 0,     // outside the rig's image, or the reflex disc beyond mirror 2 and its lip
  kMirror1 = 1,  // outer ring: the world via mirror 1
  kMirror2 = 2,  // inner ring: the world via mirror 2 and the reflex disc
  kLip1 = 3,     // the blue lip seen directly
  kLip2 = 4,     // the red lip seen through the reflex disc
  kHole = 5,     // mirror 2's central hole (the camera sees itself)
};

struct RingLayout {
  int width = 0, height = 0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // the image of mirror 1's axis
  RingBoundary hole, mirror2_rim, lip2_outer, reflex_edge, mirror1_cut, mirror1_rim, lip1_outer;

  RingLabel LabelAt(const Eigen::Vector2d& pixel) const;
  // One label per pixel (CV_8U, values of RingLabel).
  cv::Mat LabelMask() const;
  // Signed distance in pixels from `pixel` into its ring along the radius: positive inside
  // ring `mirror`, the distance to the nearer of its two boundaries; negative outside.
  double DepthInRing(const Eigen::Vector2d& pixel, Mirror mirror) const;
};

RingLayout ComputeRingLayout(const RigModel& model);

}  // namespace omni::detectors
