// What `detect` and `calibrate` share: a session's detection (detectors/detect_session.h)
// reported on the terminal.
#pragma once

#include "detectors/detect_session.h"
#include "io/session_file.h"

namespace omni::apps {

// The session detected with `rig` (detectors::DetectSessionReported): the guide's line on stdout
// (flushed, before the progress lines on stderr), each image's line and warnings under a progress
// line "detect" on stderr, then the note on repeated sheets as a warning naming the session.
// `detected` (may be empty): each detected image, as SessionDetectHooks::detected.
detectors::SessionDetection DetectOnTerminal(
    const io::Session& session, const RigParams& rig,
    const detectors::SessionDetectOptions& options,
    const decltype(detectors::SessionDetectHooks::detected)& detected = nullptr);

}  // namespace omni::apps
