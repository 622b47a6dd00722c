// The calibration's options from a session file (io/session_file.h): its estimate, priors,
// consider, solver and lips sections. Kept apart from calibrate.h, which reads no files.
#pragma once

#include "calib/calibrate.h"
#include "io/session_file.h"

namespace omni::calib {

CalibrationOptions OptionsFromSession(const io::Session& session);

}  // namespace omni::calib
