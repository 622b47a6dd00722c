#include "apps/detect_cli.h"

#include <cstdio>
#include <optional>
#include <string>

#include "apps/progress.h"

namespace omni::apps {

detectors::SessionDetection DetectOnTerminal(
    const io::Session& session, const RigParams& rig,
    const detectors::SessionDetectOptions& options,
    const decltype(detectors::SessionDetectHooks::detected)& detected) {
  std::optional<ProgressLine> progress;
  detectors::SessionDetectHooks hooks;
  hooks.before_images = [&](const std::string& guide_line) {
    if (!guide_line.empty()) std::printf("%s\n", guide_line.c_str());
    std::fflush(stdout);  // before the progress lines on stderr
    progress.emplace("detect", static_cast<int>(session.images.size()));
  };
  hooks.warning = [&](const std::string& line) { progress->Print(line); };
  hooks.image_done = [&](const std::string& line) { progress->Done(line); };
  hooks.detected = detected;
  detectors::SessionDetection found =
      detectors::DetectSessionReported(session, rig, options, hooks);
  progress->Finish();
  if (!found.repeated_note.empty()) {
    std::fprintf(stderr, "warning: %s: %s\n", session.path.c_str(), found.repeated_note.c_str());
  }
  return found;
}

}  // namespace omni::apps
