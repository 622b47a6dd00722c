// `omnistereo triangulate`: not built yet (3D sensing issue).
#include "apps/command.h"

namespace omni::apps {

int RunTriangulate() { return NotYetImplemented("triangulate", "3D sensing issue"); }

}  // namespace omni::apps
