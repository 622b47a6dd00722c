// `omnistereo detect`: not built yet (detectors issue).
#include "apps/command.h"

namespace omni::apps {

int RunDetect() { return NotYetImplemented("detect", "detectors issue"); }

}  // namespace omni::apps
