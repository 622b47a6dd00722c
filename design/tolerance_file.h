// The tolerance spec `omnistereo-tolerances/1` (YAML) read by `omnistereo tolerance`.
//
//   format: omnistereo-tolerances/1
//   mirror1: {decentre: 0.2, tilt_deg: 0.3, axial: 0.2}   # mm, rad (or *_deg), mm; each optional
//   mirror2: {decentre: 0.2, tilt_deg: 0.3, axial: 0.2}
//   reflex: {tilt_deg: 0.3, dz: 0.2}
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

// Throws io::InputError naming the file and key.
ToleranceFile ReadToleranceFile(const std::string& path);

}  // namespace omni::design
