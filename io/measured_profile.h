// A mirror's measured profile in a model file: `profile_from:` in `mirror1:` or `mirror2:`
// (docs/formats/model.md), the scan (io/profile_scan_file.h) fitted to the mirror's profile terms
// (model/profile_fit.h).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "io/yaml_reader.h"
#include "model/rig_params.h"

namespace omni::io {

// The bounds a profile in a model file keeps (model_file.cc's, for `profile:`).
struct ProfileBounds {
  double max_sag_mm = 0;  // |sag| over the profile's radii, and of every scan point
  double max_slope = 0;   // |grad sag| of the fitted terms (rad)
};

// Reads, where `mirror_map` (the map of `mirror`) has one, `profile_from: <scan.csv>` (a path
// relative to the model file `model_file`), `profile_accuracy_mm` (required: each scan point's
// stated accuracy) and `profile_max_gap_mm` (optional: the widest gap between a scan line's radii
// over the profile's radii; default a tenth of them). The profile's radii are those of the
// mirror's `profile:` map if read before, else the mirror's used annulus; that map may give radii
// and a ripple but no coefficient. Sets the mirror's profile (present, coefficients = the fit's
// terms) and rig->measured_profile. Throws InputError naming the model file and key, or the scan
// file and line: the accuracy or gap without profile_from; a missing or non-positive accuracy or
// gap; coefficients beside profile_from; kind ideal; a scan point off the mirror (inside mirror
// 2's hole, beyond the rim), unsorted, with |sag| beyond bounds.max_sag_mm, gaps wider than the
// bound; fitted terms beyond the bounds.
// Or reads `profile_measured:` (MeasuredProfileText: a fit written with a model, the scan not
// needed), whose coefficients are those of the mirror's `profile:` map (a calibrated model's
// values); refused beside profile_from, without a profile map, or with a malformed map.
void ReadMeasuredProfile(const Reader& in, const std::string& model_file,
                         const YAML::Node& mirror_map, Mirror mirror, const ProfileBounds& bounds,
                         RigParams* rig);

// The lines ModelFileText writes for a mirror's measured profile ("" without one):
// `profile_measured: {scan, accuracy_mm, points, piston_mm, residual_pv_mm, residual_rms_mm,
// terms (the measured ones), sag (the fit's six terms), covariance (6 x 6, row-major)}`, so
// that a written model (a calibrated one: its `profile:` the calibration's values) carries the
// prior it was calibrated with, without the scan.
std::string MeasuredProfileText(const RigParams& rig, Mirror mirror);

}  // namespace omni::io
