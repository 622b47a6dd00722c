// `omnistereo tolerance`: not built yet (calibration issue).
#include "apps/command.h"

namespace omni::apps {

int RunTolerance() { return NotYetImplemented("tolerance", "calibration issue"); }

}  // namespace omni::apps
