#include "apps/command.h"
#include "apps/common_flags.h"

DEFINE_string(curves_out, "", "folder for the sensitivity curves of the paper's section 5.2 (CSV)");

namespace omni::apps {
int RunDesign() { return NotYetImplemented("design", "foundation issue, in progress"); }
}  // namespace omni::apps
