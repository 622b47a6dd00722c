// The detect loop of a whole session, shared by `detect` and `calibrate`: every image read as the
// camera wrote it (io/image_file.h, demosaiced when the session names a Bayer pattern),
// checked against the model's size, and passed to DetectImage.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/detect_image.h"
#include "detectors/lip_guide.h"
#include "io/session_file.h"
#include "model/observations.h"

namespace omni::detectors {

// What happened to one image, for the caller's progress line.
struct ImageReport {
  size_t index = 0, total = 0;  // 0-based
  std::string file;             // as listed in the session
  bool skipped = false;         // unreadable (missing or undecodable): left out
  std::vector<std::string> warnings;  // one line each, without the file name (or the skip reason)
  int corners[2] = {0, 0};      // per ring
  // Targets of which more copies were seen in a ring than the session lists sheets of the
  // pattern (DetectImage's `repeated`): one copy per ring kept.
  std::vector<int> repeated_targets;
  double ms = 0;                // read + detect
};

// Called after each image with its report, the image as read (empty when skipped) and its
// detections (file left as listed).
using ImageCallback =
    std::function<void(const ImageReport&, const cv::Mat& image, ImageObservations* detections)>;

// Detects every image of the session. Unreadable images are skipped (reported); an image of an
// unsupported layout (io::ReadImage), or whose size is not the model's, ends the session: throws
// io::InputError naming the file and what was expected, before anything is written.
// When no image could be read at all DetectSession throws io::InputError naming the session:
// "none of the N images could be read".
// The lip guide (lip_guide.h) on a few of the session's images (LipGuideImages; an unreadable
// one replaced by the next readable image), before DetectSession: sets ctx->tone from the
// session. Skipped (why_not says so) when the session does not use the lips; *nothing_read is
// set when it does and none of the session's images can be read (the guide's line is then not
// worth printing: DetectSession reports each image and throws).
LipGuide GuideSessionByLips(const io::Session& session, DetectorContext* ctx,
                            bool* nothing_read = nullptr);

// The lip-only fit's rms (image px) up to which the model fits the lips: 0.43-0.45 px measured
// on rigs whose model has the mount's posts (or that have none), 2.0-2.4 px from an ideal
// design or with the posts left out of the model (docs/experiments.md).
constexpr double kGuideRmsFinePx = 1.0;

// The guide's line for the user (Describe), with a judgement of the fit's rms on a second line
// where there was a fit.
std::string GuideLine(const LipGuide& guide);

// Several identical sheets in the photos (ImageReport::repeated_targets), said once for the
// whole session rather than per photo.
class RepeatedSheets {
 public:
  void Add(const ImageReport& report);
  // One line: which targets, in how many photos, and what to do; empty when there were none.
  std::string Note(const std::vector<TargetSpec>& targets) const;

 private:
  std::map<int, int> photos_;  // target -> photos with a copy left out
};

Observations DetectSession(const io::Session& session, DetectorContext* ctx,
                             const ImageCallback& on_image = nullptr);

}  // namespace omni::detectors
