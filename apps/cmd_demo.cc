#include "apps/command.h"
#include "apps/common_flags.h"

namespace omni::apps {
int RunDemo() { return NotYetImplemented("demo", "foundation issue, in progress"); }
}  // namespace omni::apps
