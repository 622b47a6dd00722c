// The tolerance spec `omnistereo-tolerances/1` (YAML) read by `omnistereo tolerance`.
//
//   format: omnistereo-tolerances/1
//   mirror1: {decentre: 0.2, tilt_deg: 0.3, axial: 0.2}   # mm, rad (or *_deg), mm; each optional
//   mirror2: {decentre: 0.2, tilt_deg: 0.3, axial: 0.2}   # against the camera (its pose in C)
//   reflex: {tilt_deg: 0.3, dz: 0.2}                       # in mirror 1's body
// or the parts against each other (design/rig_body.h), each part in one frame only:
//   mirror2: {decentre_to_mirror1: 0.1, tilt_to_mirror1_deg: 0.1, spacing: 0.1, profile_pv: 0.01}
//   camera: {decentre_to_axis: 0.5, tilt_to_axis_deg: 1.0}  # not with mirror1's decentre/tilt/axial
//   confidence_sigmas: 2.0                                 # optional
//   simulate: {samples: 200, range: 1000, seed: 1}         # optional: image effect, range in mm
#pragma once

#include <string>

#include "design/tolerance.h"

namespace omni::design {

struct ToleranceFile {
  ToleranceSpec spec;
  int simulate_samples = 200;
  double simulate_range_mm = 1000;
  unsigned simulate_seed = 1;
};

// Throws io::InputError naming the file and key: a limit < 0, an unknown key in a part's map,
// a part toleranced in both frames.
ToleranceFile ReadToleranceFile(const std::string& path);

}  // namespace omni::design
