// `omnistereo demo`: the main job on the bundled default. For now: design the paper's big rig
// (sample_configs/big_rig_design.yaml) and write its ideal model; the calibration issue turns this
// into a synthetic session calibrated end to end.
#include <string>

#include "apps/command.h"
#include "apps/common_flags.h"

namespace omni::apps {

int RunDemo() {
  FLAGS_config = std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_design.yaml";
  if (FLAGS_out.empty()) FLAGS_out = "big_rig_ideal.yaml";
  return RunDesign();
}

}  // namespace omni::apps
