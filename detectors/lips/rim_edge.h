// A single mirror's rim measured in one photo, as the calibration's observation of it: the edge
// points where the mirror's image ends, labelled as the rim circle (mirror 1's r_outer circle,
// path direct: the camera sees the rim itself, not a reflection of it).
//
// Why: corners alone leave a single-mirror camera's focal length, conic constant and axial
// distance in one valley (they trade along the elevation mapping; each board's pose absorbs a
// local scale). The rim is a circle of known metric radius (the measured diameter: the model's
// r_sys) on the mirror itself, seen straight by the camera: its image pins the focal length
// against the distance (perspective lens) or the magnification (telecentric), and its centre the
// principal point against the mirror's decentre. Its height follows the conic (calib/lip_cost.h).
//
// How: the model's rim curve (model/lip.h ProjectLipPoint, direct) at `rays` azimuths; along each
// point's radial line from the curve's centre, the steepest brightness drop (inside brighter)
// within +-band of it on the linear-light grey image (sub-pixel by a parabola), kept where the
// drop is at least min_drop_fraction of the median drop (rays where the scene inside is as dark
// as the housing, or a holder crosses the rim, give none); then points more than 3 robust sigmas
// (MAD) from a fit of their offsets by the azimuth's harmonics up to the second (what a start
// off in centre, scale or tilt makes of them) are dropped. Edge
// points of a blurred step in linear light lie at its halfway level: no bias from the blur.
#pragma once

#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "model/observations.h"
#include "model/rig_model.h"

namespace omni::detectors {

struct RimEdgeOptions {
  int rays = 360;
  // The search's half-width about the model's rim: this share of the rim's image radius, at
  // least min_band_px (the start model's rim comes from the same photos' rim fit: ~1 px off).
  double band_fraction = 0.02;
  double min_band_px = 4;
  double min_drop_fraction = 0.3;
  // Fewer usable rays than this share: no observation (the rim mostly hidden or outside).
  double min_coverage = 0.3;
  std::string Check() const;
};

// The rim's edge points in `grey` (8-bit or 16-bit linear light, one channel, the model's size)
// for a single rig (RigParams::Single); nullopt where the rim is not seen well enough (`why`).
std::optional<LipEdgeObservation> DetectRimEdge(const cv::Mat& grey, const RigModel& model,
                                                const RimEdgeOptions& options = {},
                                                std::string* why = nullptr);

}  // namespace omni::detectors
