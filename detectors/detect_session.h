// The detect loop of a whole session: every image read as the camera wrote it (io/image_file.h,
// demosaiced when the session names a Bayer pattern), checked against the model's size, and
// passed to DetectImage. DetectSessionReported is the session's detection as the commands run it
// (`detect`, `calibrate` without --detections, `init`'s look at the first photos, the demo): the
// lip guide, the loop, each image's line and warnings, the session's summary.
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
  int rings = 2;                // the rig's optical paths (RigParams::Paths): 1 for a single mirror
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

// One image's progress line: "[i/n] file: A corners in ring 1, B in ring 2 (T ms)" (a single
// mirror's one ring: "A corners"); with
// `detail` also its lip edges (before the time) and, after it, the corners per target in
// ring 1 / ring 2 (what a user checks each photo by).
std::string ImageLine(const ImageReport& report, const ImageObservations& detections, bool detail);

struct SessionDetectOptions {
  // The lip guide (GuideSessionByLips) before the loop; off for a look at a few photos for the
  // lips alone (`init`'s starting intrinsics).
  bool guide_by_lips = true;
  // Each image's line with its lip edges and corners per target (ImageLine's detail).
  bool image_detail = true;
};

// Where DetectSessionReported's lines go (none set: it says nothing). Lines have no newline.
struct SessionDetectHooks {
  // After the guide, before the first image: the guide's line (GuideLine), empty when the guide
  // did not run or read none of the session's images (each image then reports itself).
  std::function<void(const std::string& guide_line)> before_images;
  // A line between images: a warning about the image that follows it.
  std::function<void(const std::string& line)> warning;
  // An image done: its ImageLine, or for a skipped image its warning.
  std::function<void(const std::string& line)> image_done;
  // An image detected (not skipped), before its line: the image as read, its detections (file
  // as listed) and the ring layout they were found with (an overlay).
  std::function<void(const ImageReport& report, const cv::Mat& image,
                     const ImageObservations& detections, const RingLayout& layout)>
      detected;
};

struct SessionDetection {
  Observations detections;  // files and session as the session lists them
  size_t skipped = 0;       // unreadable images left out
  int corners = 0;          // over every image and ring
  // RepeatedSheets::Note for the session (empty when no sheet was seen twice in a ring).
  std::string repeated_note;
};

// The session detected with the model `rig` (the session's or another: a second pass from the
// calibrated one). Warnings read "warning: FILE: what" ("; skipped" for an unreadable image).
// Throws as DetectSession does.
SessionDetection DetectSessionReported(const io::Session& session, const RigParams& rig,
                                       const SessionDetectOptions& options = {},
                                       const SessionDetectHooks& hooks = {});

// Per target of the session, one line: "  target T (name): in P of N photos, A corners in ring 1,
// B in ring 2" (a single-mirror rig, paths 1: "A corners"), with what to check when it was never
// found; newline-terminated.
std::string TargetSummary(const std::vector<TargetSpec>& targets, const Observations& detections,
                          int paths = 2);

// A lips-only session's check: the intrinsics the lips alone give against the model's, with what
// the check is worth (or why there was none); newline-terminated lines. A check, not a
// calibration: the fit puts the principal point where the mirror bodies put the lips' centres,
// which moves with their misalignment, and f absorbs the lens's radial distortion and the
// bodies' axial offsets (lips/lip_intrinsics.h: f within ~0.6%, the principal point a few px
// off on a misaligned rig).
std::string LipsOnlyCheck(const Observations& detections, const RigModel& model);

}  // namespace omni::detectors
