// What `detect` and `calibrate` share: a session's detection (detectors/detect_session.h)
// reported on the terminal.
#pragma once

#include <cstddef>
#include <optional>

#include "apps/progress.h"
#include "detectors/detect_session.h"

namespace omni::apps {

// The hooks of detectors::DetectSessionReported for the terminal: the guide's line on stdout
// (flushed, before the progress lines on stderr), then a ProgressLine `what` over the session's
// `images`, made in *progress when the images begin, with each image's line and warnings.
detectors::SessionDetectHooks ProgressHooks(const char* what, size_t images,
                                            std::optional<ProgressLine>* progress);

}  // namespace omni::apps
