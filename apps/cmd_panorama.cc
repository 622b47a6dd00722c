// `omnistereo panorama`: not built yet (3D sensing issue).
#include "apps/command.h"

namespace omni::apps {

int RunPanorama() { return NotYetImplemented("panorama", "3D sensing issue"); }

}  // namespace omni::apps
