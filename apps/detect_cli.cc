#include "apps/detect_cli.h"

#include <cstdio>
#include <string>

namespace omni::apps {

detectors::SessionDetectHooks ProgressHooks(const char* what, size_t images,
                                            std::optional<ProgressLine>* progress) {
  detectors::SessionDetectHooks hooks;
  hooks.before_images = [what, images, progress](const std::string& guide_line) {
    if (!guide_line.empty()) std::printf("%s\n", guide_line.c_str());
    std::fflush(stdout);  // before the progress lines on stderr
    progress->emplace(what, static_cast<int>(images));
  };
  hooks.warning = [progress](const std::string& line) { (*progress)->Print(line); };
  hooks.image_done = [progress](const std::string& line) { (*progress)->Done(line); };
  return hooks;
}

}  // namespace omni::apps
