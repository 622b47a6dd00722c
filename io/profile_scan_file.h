// A mirror's measured profile (`profile_from:` in a model file's mirror map, or a session's), as
// CSV (io/csv.h's dialect): a header naming the columns, then one row per measured point:
//   r_mm,sag_mm[,theta_deg]
// r_mm: the radius in the mirror's body frame; sag_mm: the surface's departure from the nominal
// conic along the body's +z axis (what a profilometer reports after removing the design form);
// theta_deg: the scan line's azimuth (several azimuths: rows grouped by scan line, each line's
// radii increasing). Without theta_deg the file is one scan line at azimuth 0.
#pragma once

#include <string>
#include <vector>

#include "model/mirror_profile.h"
#include "model/profile_fit.h"

namespace omni::io {

struct ProfileScanLimits {
  double rim_mm = 0;         // the mirror's outer radius: a radius beyond it is not on the mirror
  double hole_mm = 0;        // the radius of the mirror's central hole (mirror 2's r_cam): a
                             // radius inside it is not on the mirror
  double max_gap_mm = 0;     // widest gap between a line's radii over the profile's radii (0:
                             // a tenth of r_max - r_min)
  double max_sag_mm = 0.5;   // a larger |sag| is no profile error (the conic itself, or microns
                             // written as mm)
};

// Reads and checks a scan against the profile's radii `shape`. Throws InputError naming the file
// and line for: a missing r_mm or sag_mm column; a non-number; a radius < 0, inside the hole or
// beyond the rim; a
// radius not above the previous one of its scan line; a |sag| beyond max_sag_mm; a gap wider
// than max_gap_mm between consecutive radii of a line, or between the profile's radii and a
// line's first or last radius inside them; fewer than 10 points inside the profile's radii.
std::vector<ProfileScanPoint> ReadProfileScan(const std::string& path, const ProfileShape& shape,
                                              const ProfileScanLimits& limits);

}  // namespace omni::io
