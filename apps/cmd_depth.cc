// `omnistereo depth`: not built yet (3D sensing issue).
#include "apps/command.h"

namespace omni::apps {

int RunDepth() { return NotYetImplemented("depth", "3D sensing issue"); }

}  // namespace omni::apps
