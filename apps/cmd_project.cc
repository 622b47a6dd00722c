#include "apps/command.h"
#include "apps/common_flags.h"

namespace omni::apps {
int RunProject() { return NotYetImplemented("project", "non-central model issue"); }
int RunUnproject() { return NotYetImplemented("unproject", "non-central model issue"); }
}  // namespace omni::apps
