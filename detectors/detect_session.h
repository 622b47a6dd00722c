// The detect loop of a whole session, shared by `detect` and `calibrate`: every image read as the
// camera wrote it (model/io/image_file.h, demosaiced when the session names a Bayer pattern),
// checked against the model's size, and passed to DetectImage.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/detect_image.h"
#include "detectors/lip_guide.h"
#include "model/observations.h"
#include "model/io/session_file.h"

namespace omni::detectors {

// What happened to one image, for the caller's progress line.
struct ImageReport {
  size_t index = 0, total = 0;  // 0-based
  std::string file;             // as listed in the session
  bool skipped = false;         // unreadable (missing or undecodable): left out
  std::vector<std::string> warnings;  // one line each, without the file name (or the skip reason)
  int corners[2] = {0, 0};      // per ring
  double ms = 0;                // read + detect
};

// Called after each image with its report, the image as read (empty when skipped) and its
// detections (file left as listed).
using ImageCallback =
    std::function<void(const ImageReport&, const cv::Mat& image, ImageObservations* detections)>;

// Detects every image of the session. Unreadable images are skipped (reported); an image of an
// unsupported layout (io::ReadImage), or whose size is not the model's, ends the session: throws
// io::InputError naming the file and what was expected, before anything is written.
// The lip guide (lip_guide.h) on a few of the session's images (LipGuideImages; unreadable ones
// passed over), before DetectSession: sets ctx->tone from the session. Skipped (why_not says so)
// when the session does not use the lips.
LipGuide GuideSessionByLips(const io::Session& session, DetectorContext* ctx);

Observations DetectSession(const io::Session& session, DetectorContext* ctx,
                             const ImageCallback& on_image = nullptr);

}  // namespace omni::detectors
