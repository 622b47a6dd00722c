// `omnistereo calibrate`: not built yet (calibration issue).
#include "apps/command.h"

namespace omni::apps {

int RunCalibrate() { return NotYetImplemented("calibrate", "calibration issue"); }

}  // namespace omni::apps
