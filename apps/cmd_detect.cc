// `omnistereo detect --session S --out detections.yaml [--overlay DIR] [--model M]`: target corners of every
// kind (chessboards, AprilTag grids; per ring, with ids consistent between the rings) and lip
// band edges (colour images, when the session uses lips) in every image of a session, written as an
// `omnistereo-detections/1` file. Unreadable images (missing, empty, undecodable) get one warning
// line each and are left out; if no image is usable nothing is written and the exit code is 2.
// An image of an unsupported layout (float, 32 bit, colour with a session `bayer:` key) or not
// of the model's size stops the session with one line naming it: nothing is written.
// --overlay writes DIR/<image>.png (apps/overlay.h): the ring boundaries, corners coloured by
// ring (mirror 1 green, mirror 2 magenta), each board named once per ring and the ids that can be
// read, lip edge points as single yellow pixels, a legend.
// A lips-only session (`targets: []`) finds the lips alone and prints the intrinsics they give
// against the model's: a quick check of a new camera (or of the lips' paints) before any target
// is printed.
// --model M detects with M instead of the session's model (a second pass from the calibrated model).
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <gflags/gflags.h>
#include <opencv2/imgcodecs.hpp>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "apps/overlay.h"
#include "apps/detect_cli.h"
#include "detectors/detect_session.h"
#include "io/detections_file.h"
#include "io/file_util.h"
#include "io/model_file.h"
#include "io/session_file.h"

DEFINE_string(overlay, "", "folder for overlay PNGs (corners by ring, board names and ids, lip edge points, ring boundaries, a legend)");

namespace omni::apps {
namespace {

namespace fs = std::filesystem;

// The overlay (apps/overlay.h) of one photo, written whole or not at all.
void WriteOverlay(const std::string& path, const cv::Mat& image, const detectors::RingLayout& layout,
                  const ImageObservations& det, const std::vector<TargetSpec>& targets) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", DrawOverlay(image, layout, det, targets), png)) {
    throw std::runtime_error("cannot encode " + path);
  }
  io::WriteFileAtomically(path, std::string(png.begin(), png.end()));
}

void CreateFolder(const std::string& folder, const char* flag) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw io::InputError(std::string(flag) + " " + folder + ": cannot create the folder: " + ec.message());
}

}  // namespace

int RunDetect() {
  if (FLAGS_session.empty() || FLAGS_out.empty()) {
    throw io::InputError("--session and --out are required");
  }
  const io::Session session = io::ReadSessionFile(FLAGS_session);
  if (session.targets.empty() && !session.use_lips) {
    throw io::InputError(FLAGS_session + ": targets: [] and lips: false: nothing to detect");
  }
  // --model: another model than the session's, e.g. the calibrated one for a second pass (its
  // rings' edges and its predictions from one ring into the other are where the rig has them,
  // so guided detection finds more corners).
  const RigParams rig = io::ReadModelFile(FLAGS_model.empty() ? session.model_path : FLAGS_model);
  if (!FLAGS_overlay.empty()) CreateFolder(FLAGS_overlay, "--overlay");
  decltype(detectors::SessionDetectHooks::detected) overlay;
  if (!FLAGS_overlay.empty()) {
    overlay = [&](const detectors::ImageReport& r, const cv::Mat& image,
                  const ImageObservations& det, const detectors::RingLayout& layout) {
      WriteOverlay((fs::path(FLAGS_overlay) / (fs::path(r.file).stem().string() + ".png")).string(),
                   image, layout, det, session.targets);
    };
  }
  const detectors::SessionDetection found = DetectOnTerminal(session, rig, {}, overlay);
  io::WriteDetectionsFile(FLAGS_out, io::WithPathsRelativeToFile(found.detections, FLAGS_out));
  std::printf("%zu of %zu images used (%zu skipped), %d corners, detections in %s\n",
              found.detections.images.size(), session.images.size(), found.skipped, found.corners, FLAGS_out.c_str());
  std::printf("%s", detectors::TargetSummary(session.targets, found.detections, rig.Paths()).c_str());
  if (session.targets.empty()) {
    std::printf("%s", detectors::LipsOnlyCheck(found.detections, RigModel(rig)).c_str());
  }
  return 0;
}

}  // namespace omni::apps
